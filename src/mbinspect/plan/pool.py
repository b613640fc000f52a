"""The trials of a plan, in worker processes when there are several to run at once."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, TypeVar

__all__ = ["run_trials", "ticker"]

T = TypeVar("T")


def run_trials(trial: Callable[..., T], jobs: Sequence[tuple[Any, ...]], workers: int,
               tick: Callable[[], None] | None = None) -> list[T]:
    """``trial(*job)`` for every job, in job order, in ``min(workers, len(jobs))`` processes
    when more than one; ``tick`` is called as each result comes in (for progress).

    Examples
    --------
    >>> run_trials(pow, [(2, 3), (3, 2)], workers=1)
    [8, 9]
    """
    def done(value: T) -> T:
        if tick is not None:
            tick()
        return value

    if workers <= 1 or len(jobs) <= 1:
        return [done(trial(*job)) for job in jobs]
    from concurrent.futures import ProcessPoolExecutor

    with ProcessPoolExecutor(min(workers, len(jobs))) as pool:
        futures = [pool.submit(trial, *job) for job in jobs]
        return [done(f.result()) for f in futures]


def ticker(progress: Callable[[float], None] | None, total: int, done: list[int] | None = None
           ) -> Callable[[], None]:
    """A ``tick`` for :func:`run_trials`: each call counts one trial more in ``done[0]`` (kept
    by the caller across several runs, or from 0) and reports the share of ``total`` done.

    >>> shares = []
    >>> tick = ticker(shares.append, 4, [1])
    >>> tick(); tick(); shares
    [0.5, 0.75]
    """
    count = [0] if done is None else done

    def tick() -> None:
        count[0] += 1
        if progress is not None:
            progress(min(count[0] / max(total, 1), 1.0))

    return tick
