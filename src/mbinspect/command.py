"""The ``mbinspect`` console entry point.

It lives outside :mod:`mbinspect.cli` so that nothing imports numpy before two things are
set:

* the signals are handed to their watcher (:func:`mbinspect.interrupt.install`): the command
  line's package imports numpy, whose BLAS threads, started before the signals were blocked,
  would take a SIGTERM with its default action and end the process with nothing said and
  something left behind;
* numpy's request for transparent huge pages is off unless the user set
  ``NUMPY_MADVISE_HUGEPAGE`` (:mod:`mbinspect.pages`).
"""

from __future__ import annotations

import sys
from typing import NoReturn

__all__ = ["run", "prepare"]


def prepare() -> None:
    """What must precede numpy's import: small pages (:func:`mbinspect.pages.small_pages`),
    then the signals to their watcher."""
    from .interrupt import install
    from .pages import small_pages

    small_pages()
    install()


def run() -> NoReturn:
    """:func:`prepare`, then :func:`mbinspect.cli.main` and its exit status."""
    prepare()
    from .cli import main

    sys.exit(main())
