"""Ctrl-C and SIGTERM for the command line: out within a second, nothing left behind.

:func:`install` blocks SIGINT and SIGTERM in the main thread (and so in every thread and
process it starts) and hands them to a watcher thread. On a signal the watcher asks the
main thread to stop (a ``KeyboardInterrupt`` there unwinds the work, removing staging
folders and ending reader workers); if the main thread is still busy in compiled code
after :data:`GRACE` seconds, the watcher removes what is unfinished
(:func:`mbinspect.outputs.discard_unfinished`), kills the workers and ends the process
itself. The exit status is 130 for SIGINT and 143 for SIGTERM; a second signal meanwhile
changes nothing. Reader workers ignore SIGINT and, on Linux, die with their parent
however it dies (``mbinspect.io``).
"""

from __future__ import annotations

import _thread
import logging
import os
import signal
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["install", "exit_status", "signals_kept_blocked", "GRACE"]

#: Seconds the main thread gets to unwind by itself before the process is ended.
GRACE = 0.6

_EXIT = {signal.SIGINT: 130, signal.SIGTERM: 143}
_received: list[int] = []


def exit_status() -> int:
    """The exit status for the interrupt received: 143 after SIGTERM, else 130."""
    return _EXIT.get(signal.Signals(_received[0]), 130) if _received else 130


def install() -> None:
    """Hand SIGINT and SIGTERM to a watcher thread (call once, from the main thread, before
    any library that starts threads, numpy's BLAS among them, is imported: a thread started
    earlier does not block them and would take the signal)."""
    sigs = {signal.SIGINT, signal.SIGTERM}
    signal.pthread_sigmask(signal.SIG_BLOCK, sigs)
    threading.Thread(target=_watch, args=(sigs,), name="mbinspect-signals", daemon=True).start()


def _watch(sigs: set[signal.Signals]) -> None:
    sig = signal.sigwait(sigs)
    _received.append(int(sig))
    _quiet()
    main = threading.main_thread()
    _thread.interrupt_main()
    main.join(GRACE)
    # the main thread is stuck in compiled code (or waiting on workers): end it here
    try:
        from .outputs import discard_unfinished

        os.write(2, b"mbinspect: interrupted\n")
        discard_unfinished()
        import multiprocessing

        for child in multiprocessing.active_children():
            child.kill()
    finally:
        os._exit(exit_status())


def _quiet() -> None:
    """From here only our one line speaks: a library logging the workers it was starting as
    they were stopped (Dask's nanny: "Failed to start process"; the client's event loop:
    "Exception in callback" and a traceback), an exception a thread or a finaliser raises
    while the work unwinds: logging is off and the exception hooks do nothing."""
    logging.disable(logging.CRITICAL)
    sys.unraisablehook = lambda _: None
    threading.excepthook = lambda _: None


@contextmanager
def signals_kept_blocked() -> Iterator[None]:
    """The calling thread's signal mask as it was, whatever the block starts: Python's
    multiprocessing unblocks SIGINT and SIGTERM in the thread that starts its resource
    tracker (a fork server's first use does), and a Ctrl-C then reached the main thread
    itself, not the watcher: no one silenced the libraries, and a traceback came out."""
    if not hasattr(signal, "pthread_sigmask"):  # Windows: no masks to keep
        yield
        return
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, set())
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)
