"""The ``mbinspect`` console entry point.

It lives outside :mod:`mbinspect.cli` so that nothing imports numpy before the signals are
handed to their watcher (:func:`mbinspect.interrupt.install`): the command line's package
imports numpy, whose BLAS threads, started before the signals were blocked, would take a
SIGTERM with its default action and end the process with nothing said and something left
behind.
"""

from __future__ import annotations

import sys
from typing import NoReturn

__all__ = ["run"]


def run() -> NoReturn:
    """Signals to the watcher, then :func:`mbinspect.cli.main` and its exit status."""
    from .interrupt import install

    install()
    from .cli import main

    sys.exit(main())
