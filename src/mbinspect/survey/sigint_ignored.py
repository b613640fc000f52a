"""Imported first by the fork server of the local cluster's workers (a preload): SIGINT is
ignored there from then on, and every worker it forks keeps that (a fork server restores,
in each child, the handlers it found when it started). Ctrl-C reaches every process of the
terminal's group; the command line stops the workers itself (:mod:`mbinspect.interrupt`).

The command line starts the server with SIGINT and SIGTERM blocked (a Ctrl-C while it
starts waits, then is dropped here); both are unblocked once SIGINT is ignored, so that the
workers die on SIGTERM as their nanny asks."""

import signal

signal.signal(signal.SIGINT, signal.SIG_IGN)
signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT, signal.SIGTERM})
