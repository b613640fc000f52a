"""Where the tiles run: in this process, on a local Dask cluster sized to the machine, or on
a scheduler's cluster; the progress over tasks with the time left."""

from __future__ import annotations

import logging
import os
import re
import threading
import time
import warnings
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

from ..errors import InputWarning, MBInspectError, ParameterError
from ..grid import machine_memory
from ..interrupt import signals_kept_blocked
from ..pages import small_pages_for_children

__all__ = ["machine_memory", "dask_client", "map_tasks", "eta_text", "scheduler_address"]

#: Progress callback: tasks done, tasks in all, seconds left (None before the first is done).
Progress = Callable[[int, int, float | None], None]




def scheduler_address(name: str, value: str) -> str:
    """``value`` checked as a Dask scheduler's address (``tcp://HOST:PORT``).

    Parameters
    ----------
    name : str
        The option's name.
    value : str

    Returns
    -------
    str

    Examples
    --------
    >>> scheduler_address("scheduler", "tcp://10.0.0.5:8786")
    'tcp://10.0.0.5:8786'
    """
    if not isinstance(value, str) or not re.fullmatch(r"(tcp|tls|inproc|ucx|ws|wss)://[^\s:/]+:\d+/?", value):
        raise ParameterError(f"{name}: {value!r}; expected the address of a running Dask scheduler, "
                             "tcp://HOST:PORT", option=name)
    return value


@contextmanager
def dask_client(*, scheduler: str | None = None, workers: int | None = None,
                memory_per_worker: float | None = None) -> Iterator[Any]:
    """A Dask client: on the scheduler at ``scheduler`` (``tcp://host:port``), else on a
    local cluster of ``workers`` processes (default: one per core) of one thread each,
    closed on leaving (also on Ctrl-C).

    Parameters
    ----------
    scheduler : str, optional
    workers : int, optional
    memory_per_worker : float, optional
        Bytes a local worker may use before Dask pauses and restarts it.
    """
    from dask.distributed import Client, LocalCluster

    if scheduler is not None:
        scheduler_address("scheduler", scheduler)
        try:
            client = Client(scheduler, timeout="15s")
        except (OSError, TimeoutError, ValueError) as exc:
            raise ParameterError(f"scheduler: {scheduler}: cannot connect ({exc}); expected the address "
                                 "of a running Dask scheduler, tcp://HOST:PORT", option="scheduler") from None
        try:
            yield client
        finally:
            client.close()
        return
    cores = os.cpu_count() or 1
    n = workers or cores
    if n > cores:
        warnings.warn(f"workers: {n} asked on a machine of {cores} cores: {cores} used (more processes than "
                      "cores only share them, each with less memory)", InputWarning, stacklevel=3)
        n = cores
    memory = memory_per_worker or machine_memory() * 0.8 / n
    with _workers_ignore_sigint():
        try:
            with signals_kept_blocked():
                cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                       memory_limit=int(memory), dashboard_address=None,
                                       silence_logs=logging.ERROR, host="127.0.0.1")
        except KeyboardInterrupt:
            _abandon_cluster()
            raise
        with signals_kept_blocked():
            client = Client(cluster)
        try:
            yield client
        except KeyboardInterrupt:
            _abandon_cluster()
            raise
        finally:
            client.close()
            cluster.close()


def _abandon_cluster() -> None:
    """On Ctrl-C: the workers killed now (one still starting would speak up), and Dask's
    exit-time closing of a cluster interrupted while it started (an assertion's traceback)
    skipped."""
    import multiprocessing

    from distributed.deploy.spec import SpecCluster

    for child in multiprocessing.active_children():
        child.kill()
    SpecCluster._instances.clear()


@contextmanager
def _workers_ignore_sigint() -> Iterator[None]:
    """Local workers born ignoring SIGINT: forked by a fork server that ignores it.

    Ctrl-C reaches every process of the terminal's group: the workers took it too, and each
    printed a KeyboardInterrupt traceback (4 of 16 interrupted runs). This process stops
    them itself (:mod:`mbinspect.interrupt`). The fork server starts with SIGINT blocked and
    imports :mod:`mbinspect.survey.sigint_ignored` first, so it and every worker it forks
    ignore SIGINT; this process keeps its own handling throughout (ignoring it here while
    the server started lost a Ctrl-C that came then; a server that took one while importing
    its preload died, and its nanny's traceback came out).
    The fork server and its workers write nothing to the terminal (their stderr is the null
    device): a worker still being born when this process ends printed a traceback; a task's
    error comes back through Dask, and a worker's death is reported by its nanny, here.
    """
    import multiprocessing
    from multiprocessing import forkserver, resource_tracker

    import dask

    if "forkserver" not in multiprocessing.get_all_start_methods():
        yield
        return
    with dask.config.set({"distributed.worker.multiprocessing-method": "forkserver"}), \
            small_pages_for_children():  # the server imports numpy: small pages (mbinspect.pages)
        from distributed.utils import get_mp_context

        ctx = get_mp_context()  # the server's preload (distributed, numpy, ...), set before it starts
        server = getattr(forkserver, "_forkserver", None)
        preload = [m for m in getattr(server, "_preload_modules", None) or [] if m != _QUIET]
        ctx.set_forkserver_preload([_QUIET, *preload])
        if threading.current_thread() is threading.main_thread():
            stderr = os.dup(2)
            devnull = os.open(os.devnull, os.O_WRONLY)
            try:
                os.dup2(devnull, 2)
                # the resource tracker unblocks SIGINT and SIGTERM in the thread that starts it:
                # started first, on its own, the fork server then starts with them still
                # blocked (this thread's mask), and cannot die of a Ctrl-C before its preload
                with signals_kept_blocked():
                    resource_tracker.ensure_running()
                with signals_kept_blocked():
                    forkserver.ensure_running()
            finally:
                os.dup2(stderr, 2)
                os.close(stderr)
                os.close(devnull)
        yield


#: The module the workers' fork server imports first (:mod:`mbinspect.survey.sigint_ignored`).
_QUIET = "mbinspect.survey.sigint_ignored"


def map_tasks(fn: Callable[..., Any], items: Sequence[Any], *, client: Any = None,
              progress: Progress | None = None, retries: int = 2, **kwargs: Any) -> list[Any]:
    """``[fn(item, **kwargs) for item in items]``, on ``client``'s cluster when given.

    A task whose worker dies is run again elsewhere by the scheduler; a task that raises
    is retried ``retries`` times, then its error is raised here. Results come back in the
    order of ``items``.
    """
    total = len(items)
    start = time.perf_counter()

    def tell(done: int) -> None:
        if progress is not None:
            took = time.perf_counter() - start
            progress(done, total, took / done * (total - done) if done else None)

    tell(0)
    if client is None:
        out = []
        for k, item in enumerate(items):
            out.append(fn(item, **kwargs))
            tell(k + 1)
        return out
    from dask.distributed import as_completed

    futures = [client.submit(_guarded, fn, item, pure=False, retries=retries, **kwargs) for item in items]
    try:
        for done, _ in enumerate(as_completed(futures), start=1):
            tell(done)
        out = list(client.gather(futures))
    finally:
        for f in futures:
            f.release()
    for got in out:
        if isinstance(got, _Refused):  # a user's mistake in a task: raised here, as in-process
            raise got.kind(got.message, option=got.option)
    return out


@dataclass(frozen=True)
class _Refused:
    """A task's own error (a bad file, a bad option), carried back as a value: not retried
    like a dead worker, not logged by Dask as a failed computation with its traceback."""

    kind: type
    message: str
    option: str | None


def _guarded(fn: Callable[..., Any], item: Any, **kwargs: Any) -> Any:
    try:
        return fn(item, **kwargs)
    except MBInspectError as exc:
        return _Refused(type(exc), str(exc), exc.option)


def eta_text(seconds: float | None) -> str:
    """``about 2 min 10 s left``.

    Examples
    --------
    >>> eta_text(130.4), eta_text(None), eta_text(3.2)
    ('about 2 min 10 s left', 'estimating the time left', 'about 3 s left')
    """
    if seconds is None:
        return "estimating the time left"
    s = int(round(seconds))
    if s >= 3600:
        return f"about {s // 3600} h {s % 3600 // 60} min left"
    if s >= 60:
        return f"about {s // 60} min {s % 60} s left"
    return f"about {s} s left"
