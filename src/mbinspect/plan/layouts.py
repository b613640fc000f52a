"""Candidate line layouts round a structure, generated from its design, and their time on site.

A structure's frame is the minimum-area rectangle of its pile (or unit) centres: ``u`` along
its long side, ``v`` across. Lines run along ``u`` or ``v``, outside the structure at an
offset from its outer row, or over a row of tops; each family is sailed one way (lines
alternate their heading, as a boat sails a racetrack) or both ways.

Examples
--------
>>> f = structure_frame(np.array([[0.0, 0.0], [22.0, 0.0], [0.0, 22.0], [22.0, 22.0]]), radius=0.75)
>>> round(f.half_u, 1), round(f.half_v, 1), len(f.rows), len(f.columns)
(11.0, 11.0, 2, 2)
>>> names = [c.name for c in candidates(f, offsets=(12.5,), margin=20.0)]
>>> "hash-12.5" in names and "hash-12.5+tops" in names
True
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..geometry import bearing_to_vector, min_area_rectangle, vector_to_bearing

__all__ = ["Frame", "Layout", "PlanLine", "at_speed", "candidates", "racetrack", "offsets_for",
           "structure_frame", "with_both_ways", "with_tops_both_ways"]

#: One knot in m/s.
KNOT = 1852.0 / 3600.0


@dataclass(frozen=True)
class PlanLine:
    """A straight survey line from ``start`` to ``end`` (x, y in the design's CRS, m)."""

    start: tuple[float, float]
    end: tuple[float, float]

    @property
    def length(self) -> float:
        return math.hypot(self.end[0] - self.start[0], self.end[1] - self.start[1])

    @property
    def heading(self) -> float:
        """Bearing sailed, degrees clockwise from grid north."""
        return vector_to_bearing(np.subtract(self.end, self.start))

    def reversed(self) -> PlanLine:
        return PlanLine(self.end, self.start)

    def to_dict(self) -> dict[str, Any]:
        return {"x_start": self.start[0], "y_start": self.start[1], "x_end": self.end[0],
                "y_end": self.end[1], "heading": self.heading, "length": self.length}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> PlanLine:
        return cls((float(d["x_start"]), float(d["y_start"])), (float(d["x_end"]), float(d["y_end"])))


@dataclass(frozen=True)
class Layout:
    """A candidate: its name, what it is in words, its lines in the order sailed, the speed
    (m/s) they are sailed at when it is not the plan's (:func:`at_speed`), and which of its
    lines run over a row of tops (one flag per line; empty: none)."""

    name: str
    description: str
    lines: tuple[PlanLine, ...]
    speed: float | None = None
    over_tops: tuple[bool, ...] = ()

    def time_on_site(self, speed: float, turn_s: float) -> float:
        """Seconds on site: every line at the layout's speed, else ``speed`` (m/s), and a turn
        of ``turn_s`` between lines."""
        sailing = sum(line.length for line in self.lines) / (self.speed or speed)
        return sailing + turn_s * max(len(self.lines) - 1, 0)


@dataclass(frozen=True)
class Frame:
    """A structure's frame: centre, unit axes ``u`` (long side) and ``v``, half extents of the
    centres along each, and the rows (``v`` of each row along ``u``) and columns (``u`` of each)."""

    centre: tuple[float, float]
    u: tuple[float, float]
    v: tuple[float, float]
    half_u: float
    half_v: float
    rows: tuple[float, ...]
    columns: tuple[float, ...]
    spans: tuple[tuple[float, float], ...] = ()

    def point(self, a: float, b: float) -> tuple[float, float]:
        """The world point ``a`` along ``u`` and ``b`` along ``v`` from the centre."""
        return (self.centre[0] + a * self.u[0] + b * self.v[0],
                self.centre[1] + a * self.u[1] + b * self.v[1])


def _clusters(values: np.ndarray, gap: float) -> tuple[float, ...]:
    """Means of the runs of sorted values no more than ``gap`` apart."""
    s = np.sort(values)
    cuts = np.flatnonzero(np.diff(s) > gap) + 1
    return tuple(float(np.mean(part)) for part in np.split(s, cuts))


def structure_frame(xy: np.ndarray, *, radius: float, groups: Sequence[int] | None = None) -> Frame:
    """The frame of the centres ``xy`` (N, 2): rows and columns gather centres within a
    pile's diameter and a metre of each other; ``spans`` are each jacket's (``groups``)
    extent along ``u``."""
    xy = np.asarray(xy, np.float64)
    rect = min_area_rectangle(xy) if len(xy) > 1 else None
    bearing = rect.bearing_deg if rect is not None and rect.length > 0 else 90.0
    u = bearing_to_vector(bearing)
    v = np.array([-u[1], u[0]])
    c = np.array([rect.cx, rect.cy]) if rect is not None else xy[0]
    a, b = (xy - c) @ u, (xy - c) @ v
    gap = 2 * radius + 1.0
    g = np.zeros(len(xy), int) if groups is None else np.asarray(groups)
    spans = tuple(sorted((float(a[g == k].min()), float(a[g == k].max())) for k in np.unique(g)))
    return Frame((float(c[0]), float(c[1])), (float(u[0]), float(u[1])), (float(v[0]), float(v[1])),
                 float(np.abs(a).max()), float(np.abs(b).max()), _clusters(b, gap), _clusters(a, gap),
                 spans)


#: The pile paper's '#': lines "generally 10-15 m" from piles whose tops stood 16 m down, under a
#: 120-degree swath; the middle of that range as a share of the distance at which such a top is
#: seen at the swath's edge (12.5 m of 27.7 m: 0.45).
PAPER_SHARE = 12.5 / (16.0 * math.tan(math.radians(60.0)))


def offsets_for(top_depth: float, max_angle_deg: float) -> tuple[float, ...]:
    """Offsets (m) of lines outside the outer row, as shares of the distance at which a pile
    top ``top_depth`` m below the transducer is seen at the swath's edge, to 0.5 m: 0.3 (the
    near sides seen at steep beams) and the pile paper's own (:data:`PAPER_SHARE`; farther
    lines see the far row's faces past the swath's edge only).

    >>> offsets_for(16.0, 60.0)
    (8.5, 12.5)
    """
    reach = top_depth * math.tan(math.radians(max_angle_deg))
    return tuple(sorted({max(round(f * reach * 2) / 2, 1.0) for f in (0.3, PAPER_SHARE)}))


def _along(f: Frame, b: float, margin: float, forward: bool) -> PlanLine:
    line = PlanLine(f.point(-f.half_u - margin, b), f.point(f.half_u + margin, b))
    return line if forward else line.reversed()


def _across(f: Frame, a: float, margin: float, forward: bool) -> PlanLine:
    line = PlanLine(f.point(a, -f.half_v - margin), f.point(a, f.half_v + margin))
    return line if forward else line.reversed()


def racetrack(lines: Sequence[PlanLine]) -> tuple[PlanLine, ...]:
    """The lines with every other one reversed, so that each starts near where the last ended."""
    out: list[PlanLine] = []
    for line in lines:
        if out:
            end = out[-1].end
            d_keep = math.dist(end, line.start)
            d_flip = math.dist(end, line.end)
            line = line if d_keep <= d_flip else line.reversed()
        out.append(line)
    return tuple(out)


def _across_at(f: Frame, offset: float) -> list[float]:
    """Where lines across the structure run: ``offset`` outside each jacket's end columns,
    two closer than 2 m taken as one."""
    spans = f.spans or ((-f.half_u, f.half_u),)
    at = sorted(x for lo, hi in spans for x in (lo - offset, hi + offset))
    out: list[float] = []
    for x in at:
        if out and x - out[-1] < 2.0:
            out[-1] = (out[-1] + x) / 2
        else:
            out.append(x)
    return out


def _square(f: Frame) -> bool:
    """As many rows as columns and the same extent both ways (within a metre)."""
    return len(f.rows) == len(f.columns) and abs(f.half_u - f.half_v) < 1.0


def candidates(f: Frame, *, offsets: Sequence[float], margin: float) -> list[Layout]:
    """Every candidate sailed one way: for each offset, a pair of lines along the structure
    (``along``), a pair across it (``across``), both (the '#' of the pile paper, ``hash``) and
    the '#' with lines over the rows of tops (``+tops``); and lines over the tops alone
    (``tops``, and ``tops-grid`` over the columns too)."""
    tops_u = [_along(f, b, margin, True) for b in f.rows]
    tops_v = [_across(f, a, margin, True) for a in f.columns]
    out = [Layout("tops", f"{len(tops_u)} lines over the rows of tops, along the structure",
                  racetrack(tops_u), over_tops=(True,) * len(tops_u))]
    if len(f.columns) > 1 and len(f.rows) > 1:
        out.append(Layout("tops-grid", f"{len(tops_u) + len(tops_v)} lines over the rows and columns of tops",
                          racetrack(tops_u + tops_v), over_tops=(True,) * len(tops_u + tops_v)))
    for o in offsets:
        along = [_along(f, -f.half_v - o, margin, True), _along(f, f.half_v + o, margin, False)]
        across = [_across(f, a, margin, True) for a in _across_at(f, o)]
        out.append(Layout(f"along-{o:g}", f"2 lines along the structure, {o:g} m outside its outer rows",
                          racetrack(along)))
        if not _square(f):  # across a square structure is along it turned
            out.append(Layout(f"across-{o:g}", f"{len(across)} lines across the structure, {o:g} m outside "
                              "each jacket's end columns", racetrack(across)))
        out += [
            Layout(f"hash-{o:g}", f"the '#': {len(along + across)} lines {o:g} m outside the piles",
                   racetrack(along + across)),
            Layout(f"hash-{o:g}+tops", f"the '#' at {o:g} m and {len(tops_u)} lines over the rows of tops",
                   racetrack(along + across + tops_u),
                   over_tops=(False,) * len(along + across) + (True,) * len(tops_u)),
        ]
    return out


def _sailed_again(layout: Layout, again: Sequence[bool], suffix: str, said: str) -> Layout:
    """The layout with each line marked in ``again`` followed by itself on the reciprocal
    heading (the others once), named with ``suffix`` before its speed and described with
    ``said``; its flags of lines over the tops kept line by line."""
    lines: list[PlanLine] = []
    flags: list[bool] = []
    tops = layout.over_tops or (False,) * len(layout.lines)
    for line, top, twice in zip(layout.lines, tops, again, strict=True):
        lines += [line, line.reversed()] if twice else [line]
        flags += [top] * (2 if twice else 1)
    base, at, pace = layout.name.partition("@")
    return Layout(f"{base}{suffix}{at}{pace}", layout.description + said, tuple(lines), layout.speed,
                  tuple(flags) if layout.over_tops else ())


def with_both_ways(layout: Layout) -> Layout:
    """The layout with every line sailed a second time on the reciprocal heading."""
    return _sailed_again(layout, (True,) * len(layout.lines), "x2", ", each line sailed both ways")


def with_tops_both_ways(layout: Layout) -> Layout | None:
    """The layout with each line over a row of tops sailed a second time on the reciprocal
    heading, the others once (None when it has no line over the tops, or has them all): a
    step between a layout and :func:`with_both_ways`, for fewer lines and turns.

    >>> f = structure_frame(np.array([[0.0, 0.0], [22.0, 0.0], [0.0, 22.0], [22.0, 22.0]]), radius=0.75)
    >>> lay = next(c for c in candidates(f, offsets=(8.5,), margin=20.0) if c.name == "hash-8.5+tops")
    >>> both = with_tops_both_ways(at_speed(lay, 2.0))
    >>> both.name, len(lay.lines), len(both.lines), sum(both.over_tops)
    ('hash-8.5+tops2way@2kn', 6, 8, 4)
    """
    if not any(layout.over_tops) or all(layout.over_tops):
        return None
    return _sailed_again(layout, layout.over_tops, "2way", ", the lines over the tops sailed both ways")


def at_speed(layout: Layout, knots: float) -> Layout:
    """The layout with its lines sailed at ``knots`` (more pings on each pile, longer on site).

    >>> line = PlanLine((0.0, 0.0), (100.0, 0.0))
    >>> slow = at_speed(Layout("hash-8.5", "the '#'", (line,)), 2.0)
    >>> slow.name, round(slow.time_on_site(2.0, 180.0))
    ('hash-8.5@2kn', 97)
    """
    return Layout(f"{layout.name}@{knots:g}kn", f"{layout.description}, sailed at {knots:g} kn", layout.lines,
                  knots * KNOT, layout.over_tops)
