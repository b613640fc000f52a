"""Where an ASCII file's parsed columns go: x y z and one array per other field,
allocated once for the file's row bound and filled chunk by chunk.

The arrays are allocated for at most the file's line count (pages never written are never
resident). A chunk parsed elsewhere (a worker process) is copied in at the next free row;
a chunk the compiled parser wrote in place, from its own row bound on, is moved down to
the next free row when comments or blank lines left a gap before it. So a read holds the
parsed values about once, never the whole text.
"""

from __future__ import annotations

from collections.abc import Sequence
from itertools import accumulate

import numpy as np

__all__ = ["Columns"]


class Columns:
    """The columns of one read.

    ``slot[k]`` says where the file's column ``k`` goes: 0-2 the column of ``xyz``,
    ``3 + f`` the row ``f`` of ``fields`` (named ``names[f]``), -1 nowhere. Chunk ``k``
    may be written in place from row ``bases[k]`` on.
    """

    def __init__(self, columns: Sequence[str | None], bounds: Sequence[int], geographic: bool) -> None:
        x, y = ("lon", "lat") if geographic else ("x", "y")
        axes = {x: 0, y: 1, "z": 2}
        self.names = [n for n in columns if n is not None and n not in axes]
        where = {**axes, **{n: 3 + f for f, n in enumerate(self.names)}}
        self.slot = np.array([-1 if n is None else where[n] for n in columns], dtype=np.int64)
        self.bases = [0, *accumulate(bounds)][:-1]
        capacity = int(sum(bounds))
        self.xyz = np.empty((capacity, 3))
        self.fields = np.empty((len(self.names), capacity))
        self.rows = 0

    def put(self, part: np.ndarray, at: int) -> None:
        """Rows of the used columns (in the file's order) written from row ``at`` on."""
        used = self.slot[self.slot >= 0]
        stop = at + len(part)
        for j, s in enumerate(used):
            if s < 3:
                self.xyz[at:stop, s] = part[:, j]
            else:
                self.fields[s - 3, at:stop] = part[:, j]

    def take(self, part: np.ndarray | int, chunk: int) -> None:
        """Chunk ``chunk``'s rows after those taken so far: ``part`` its rows, or the
        count of rows it wrote in place from its bound on."""
        if isinstance(part, np.ndarray):
            self.put(part, self.rows)
            self.rows += len(part)
            return
        src, dst = self.bases[chunk], self.rows
        if src != dst and part:
            self.xyz[dst:dst + part] = self.xyz[src:src + part]
            self.fields[:, dst:dst + part] = self.fields[:, src:src + part]
        self.rows += part

    def arrays(self) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        n = self.rows
        return self.xyz[:n], {name: self.fields[f, :n] for f, name in enumerate(self.names)}
