"""What numpy asks of the kernel for its large arrays: small pages for our own processes.

numpy asks Linux for transparent huge pages (2 MB) for every large array. A run allocates a
few GB once, and each of those pages is zeroed (and, in a virtual machine, fetched from the
host) at its first touch: on the 3.7 M-sounding reef field that took 2.7-3.5 s of system
time against 0.9 s with 4 kB pages, 9.1-9.9 s end to end against 6.9 s
(``benchmarks/RESULTS.md``, issue 32). numpy reads ``NUMPY_MADVISE_HUGEPAGE`` once, when it
is imported; the command line (:mod:`mbinspect.command`) and the survey's local workers
(:mod:`mbinspect.survey.cluster`) set it to :data:`HUGEPAGE` unless the user did. A library
user's own process is left as it is.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["HUGEPAGE", "VARIABLE", "small_pages", "small_pages_for_children"]

#: numpy's environment variable.
VARIABLE = "NUMPY_MADVISE_HUGEPAGE"
#: Its value in our processes unless the user set it (1: numpy's default back).
HUGEPAGE = "0"


def small_pages() -> None:
    """This process (before it imports numpy) asks for small pages unless the user chose."""
    os.environ.setdefault(VARIABLE, HUGEPAGE)


@contextmanager
def small_pages_for_children() -> Iterator[None]:
    """Processes started inside (a fork server and its workers) ask for small pages unless the
    user chose; the variable is taken back out on leaving if it was not there before."""
    if VARIABLE in os.environ:
        yield
        return
    os.environ[VARIABLE] = HUGEPAGE
    try:
        yield
    finally:
        os.environ.pop(VARIABLE, None)
