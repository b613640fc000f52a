"""The ``mbinspect`` console entry point.

It lives outside :mod:`mbinspect.cli` so that nothing imports numpy before two things are
set:

* the signals are handed to their watcher (:func:`mbinspect.interrupt.install`): the command
  line's package imports numpy, whose BLAS threads, started before the signals were blocked,
  would take a SIGTERM with its default action and end the process with nothing said and
  something left behind;
* numpy's request for transparent huge pages is off unless the user set
  ``NUMPY_MADVISE_HUGEPAGE`` (:data:`HUGEPAGE`).
"""

from __future__ import annotations

import os
import sys
from typing import NoReturn

__all__ = ["run", "HUGEPAGE"]

#: ``NUMPY_MADVISE_HUGEPAGE`` for a run unless the environment sets it. numpy asks the kernel
#: for 2 MB pages for every large array; a run allocates a few GB once, and each of those
#: pages is zeroed (and, in a virtual machine, fetched from the host) at its first touch. On
#: the 3.7 M-sounding reef field that took 2.7-3.5 s of system time against 0.9 s with small
#: pages: 9.1-9.9 s end to end against 6.9 s (benchmarks/RESULTS.md, issue 32). Set the
#: variable to 1 to have numpy's default back.
HUGEPAGE = "0"


def prepare() -> None:
    """What must precede numpy's import: the memory request (:data:`HUGEPAGE`), then the
    signals to their watcher."""
    from .interrupt import install

    os.environ.setdefault("NUMPY_MADVISE_HUGEPAGE", HUGEPAGE)
    install()


def run() -> NoReturn:
    """:func:`prepare`, then :func:`mbinspect.cli.main` and its exit status."""
    prepare()
    from .cli import main

    sys.exit(main())
