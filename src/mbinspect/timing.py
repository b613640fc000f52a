"""Seconds and peak memory of each stage of a run: the budget ``-v`` prints and the
benchmarks publish (``benchmarks/bench_reefs.py --profile``).

A :class:`StageTimes` is handed to a pipeline, which calls :meth:`StageTimes.start` as it
begins and :meth:`StageTimes.lap` with a stage's name as each stage ends (the same name
twice adds up). Peak memory is this process's resident set size, sampled every 20 ms by a
thread while the laps run (Linux; 0 elsewhere).

Examples
--------
>>> times = StageTimes()
>>> times.start()
>>> _ = sum(range(1000))
>>> times.lap("sum")
>>> times.stop()
>>> [name for name, _, _ in times.rows()]
['sum']
"""

from __future__ import annotations

import os
import threading
import time

__all__ = ["StageTimes", "resident_bytes"]


def resident_bytes() -> int:
    """This process's resident set size (bytes; 0 where /proc is not there)."""
    try:
        with open(f"/proc/{os.getpid()}/statm", "rb") as fh:
            return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return 0


class StageTimes:
    """Seconds and peak resident memory by stage name, in the order first seen.

    Parameters
    ----------
    memory : bool
        Sample the resident memory while the stages run (a thread; off: peaks are 0).
    """

    def __init__(self, memory: bool = False) -> None:
        self.memory = memory
        self.started: float | None = None
        self._seconds: dict[str, float] = {}
        self._peak: dict[str, int] = {}
        self._last = 0.0
        self._running = 0
        self._stop = threading.Event()
        self._watcher: threading.Thread | None = None

    def start(self) -> None:
        """Begin the first stage (and the memory sampling)."""
        self._last = time.perf_counter()
        if self.started is None:
            self.started = self._last
        if self.memory and self._watcher is None:
            self._running = resident_bytes()
            self._stop.clear()
            self._watcher = threading.Thread(target=self._watch, daemon=True)
            self._watcher.start()

    def _watch(self) -> None:
        while not self._stop.wait(0.02):
            self._running = max(self._running, resident_bytes())

    def lap(self, name: str) -> None:
        """End the stage ``name``: the seconds since the last lap (or the start) are its."""
        now = time.perf_counter()
        self._seconds[name] = self._seconds.get(name, 0.0) + now - self._last
        if self.memory:
            self._running = max(self._running, resident_bytes())
        self._peak[name] = max(self._peak.get(name, 0), self._running)
        self._running = resident_bytes() if self.memory else 0
        self._last = now

    def stop(self) -> None:
        """End the memory sampling."""
        self._stop.set()
        if self._watcher is not None:
            self._watcher.join()
            self._watcher = None

    def rows(self) -> list[tuple[str, float, int]]:
        """``(stage, seconds, peak resident bytes)`` in the order the stages first ran."""
        return [(k, v, self._peak[k]) for k, v in self._seconds.items()]

    def total(self) -> float:
        """The seconds of all stages."""
        return sum(self._seconds.values())

    def line(self) -> str:
        """The stages on one line: ``denoise 2.1 s, terrain 0.7 s, ...``."""
        return ", ".join(f"{k} {v:.2f} s" for k, v, _ in self.rows())
