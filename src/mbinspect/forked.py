"""Independent jobs in forked worker processes while the caller goes on: a report's figures
drawn on every core while its tables are written.

A job is a callable of no arguments. The workers are forked after the jobs are known, so a
job's data (a survey's soundings, a result) reach the workers without being copied or
pickled; only each job's return value comes back. Off Linux (macOS's system libraries are
not safe to fork), in a process that may not start children (a daemonic worker of a pool or
of Dask), with one core or one job, the jobs run here, one after another, when their results
are asked for.

Examples
--------
>>> with forked([lambda: 1 + 1, lambda: "two"]) as results:
...     pass  # write what needs no job's result here
...     done = results()
>>> done
[2, 'two']
"""

from __future__ import annotations

import multiprocessing as mp
import os
import sys
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any

__all__ = ["forked", "usable_cores"]

#: The jobs of the pool being started: set before its workers fork, so that each inherits them.
_JOBS: Sequence[Callable[[], Any]] = ()


def _run(i: int) -> Any:
    return _JOBS[i]()


def usable_cores() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


@contextmanager
def forked(jobs: Sequence[Callable[[], Any]],
           workers: int | None = None) -> Iterator[Callable[[], list[Any]]]:
    """Start ``jobs`` in forked processes; yield a function that waits for their results.

    Parameters
    ----------
    jobs : sequence of callables
        Independent jobs of no arguments; the slowest first keeps the workers evenly busy.
    workers : int, optional
        Processes at most (default: the usable cores).

    Yields
    ------
    callable
        ``results() -> list``: every job's return value, in the order of ``jobs`` (a job's
        exception is raised here).
    """
    global _JOBS
    n = min(workers or usable_cores(), len(jobs))
    if n < 2 or not sys.platform.startswith("linux") or mp.current_process().daemon or _JOBS:
        yield lambda: [job() for job in jobs]
        return
    from concurrent.futures import ProcessPoolExecutor

    _JOBS = jobs
    pool = ProcessPoolExecutor(n, mp_context=mp.get_context("fork"))
    try:
        futures = [pool.submit(_run, i) for i in range(len(jobs))]  # the workers fork here
        _JOBS = ()
        yield lambda: [f.result() for f in futures]
    finally:
        _JOBS = ()
        pool.shutdown(wait=True, cancel_futures=True)
