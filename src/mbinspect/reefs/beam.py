"""Stage 5c: each footprint seen through the beam, and the bloom taken off its edges.

A beam of finite width hears a reef's concrete before its axis reaches it: where the part of
the cone that lies on the reef, weighted by the beam's pattern and by the concrete's echo over
the seabed's (``beam_contrast_db``), outweighs the part on the seabed, the detection returns
the reef's range, placed on the beam's axis beyond the reef's edge (a "bloom"; about the
footprint's width at 20 dB). So the footprint the soundings draw is the true one blurred by
the cone and cut where the reef's share of the echo passes ``1 / (1 + contrast)``.

:func:`reach` casts the cone (the sonar's own detection, :mod:`mbinspect.beam`) at a straight
edge of a level-topped reef set ever farther from the beam's axis, at the footprint's median
range, beam angle and height, for :data:`DIRECTIONS` edge directions turned from the lines'
heading, and records how far past the edge the soundings still stand on the reef: along the
track about a footprint, on the far side less, on the near side (where the lit wall answers
first) almost nothing. :func:`structure` makes those reaches a structuring element, and
:func:`unbloom_parts` closes and erodes each footprint by it (on cells :data:`SUB` times
finer than the raster's). The cells taken off are the bloom; the soundings behind them are no
longer the reef's (its top, its shape tests and its least depth use the rest).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from ..beam import (
    DEFAULT_CONTRAST_DB,
    Beam,
    cone_directions,
    detect,
    echo_contrast_db,
    echo_energy,
    frame,
    window,
)
from ..grid import cell_index
from ..pings import ping_geometry
from ..reef_designs import Grow
from .footprint import Raster
from .measure import own_soundings, soundings_around

__all__ = ["Bloom", "Sight", "sight", "reach", "structure", "contrast_db", "unbloom_parts", "heard_rows"]



@dataclass(frozen=True, eq=False)
class Sight:
    """How each sounding was seen: its beam's origin and swath axis (NaN where unknown,
    :func:`~mbinspect.pings.ping_geometry`), the beam, and the reef's echo over the seabed's."""

    origins: np.ndarray
    axes: np.ndarray
    beam: Beam
    contrast_db: float

    def subset(self, rows: np.ndarray) -> Sight:
        """The same for the soundings ``rows``."""
        return Sight(self.origins[rows], self.axes[rows], self.beam, self.contrast_db)


def contrast_db(intensity: np.ndarray | None, is_reef: np.ndarray, height: np.ndarray) -> float:
    """The reefs' echo over the seabed's (dB, :func:`~mbinspect.beam.echo_contrast_db`): the
    reef soundings in the upper half of their heights against the other soundings;
    :data:`~mbinspect.beam.DEFAULT_CONTRAST_DB` without intensities or with fewer than 10 of either."""
    if intensity is None or is_reef.sum() < 10 or (~is_reef).sum() < 10:
        return DEFAULT_CONTRAST_DB
    top = is_reef & (height >= 0.5 * float(np.nanpercentile(height[is_reef], 95)))
    return echo_contrast_db(intensity[top], intensity[~is_reef])


def sight(points: np.ndarray, ping: np.ndarray | None, beam_angle: np.ndarray | None, beam: Beam,
          contrast: float, seabed: np.ndarray | None = None) -> Sight:
    """Each sounding's beam origin and swath axis from its ping's soundings (those of the
    ``seabed`` where given: a reef under the nadir beams would lift the transducer by its
    height); where the pings are unknown, a transducer at the water surface above the
    sounding (elevation 0) and no axis."""
    pts = np.asarray(points, np.float64)
    if ping is not None and beam_angle is not None:
        origins, axes, _ = ping_geometry(pts, ping, beam_angle, fit=seabed)
    else:
        origins, axes = np.full_like(pts, np.nan), np.full_like(pts, np.nan)
    unknown = ~np.isfinite(origins[:, 0])
    origins[unknown] = np.column_stack([pts[unknown, :2], np.zeros(int(unknown.sum()))])
    return Sight(origins, axes, beam, contrast)


#: Edge directions at which the bloom's reach is cast (the outward normal turned in equal steps
#: from "away from the sonar across the track").
DIRECTIONS = 16
#: Sub-rays per axis the reach is cast with: a real beam's pattern is continuous, and with
#: few sub-rays the reach jumps by half a footprint as the contrast crosses a step.
FINE = 9
#: Sub-cells per raster cell on a side the footprint is eroded on: a reach of 0.1-0.2 m (a
#: narrow beam) is one or two 0.1 m cells, and whole cells would take up to one too few.
SUB = 2


def _edge_hits(normal: np.ndarray, s: np.ndarray, d: np.ndarray, top: float, bed: float
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where each sub-ray (directions ``d`` (S, 3) from the origin, the axis first) first meets
    a reef whose level top (elevation ``top``) ends at a straight edge of outward plan
    ``normal``, ``s`` (M,) before the axis's crossing of the top, over a level seabed at
    ``bed``: ranges, cosines of incidence and whether on the reef, (M, S) each."""
    t_top, t_bed = top / d[:, 2], bed / d[:, 2]
    along_n = d[:, :2] @ normal  # each sub-ray's plan travel along the normal per metre of range
    at_top = along_n * t_top - along_n[0] * t_top[0]  # its crossing of the top, from the axis's
    edge = -s[:, None]
    on_top = at_top[None, :] < edge
    with np.errstate(divide="ignore", invalid="ignore"):
        # below the top the sub-ray moves on along the normal; it meets the wall where it crosses the edge
        t_wall = (edge + along_n[0] * t_top[0]) / along_n[None, :]
    wall = ~on_top & (along_n[None, :] < 0) & (t_wall > t_top[None, :]) & (t_wall < t_bed[None, :])
    rng = np.where(on_top, t_top[None, :], np.where(wall, t_wall, t_bed[None, :]))
    cos = np.where(wall, -along_n[None, :], -d[None, :, 2])  # (M, S) by broadcasting
    return rng, cos, on_top | wall


def reach(beam: Beam, rng: float, cos_angle: float, height: float, contrast: float, *,
          min_height: float = 0.3, directions: int = DIRECTIONS) -> np.ndarray:
    """How far beyond a straight edge of a reef ``height`` m tall, whose top the beam axis
    meets ``rng`` m away at ``arccos(cos_angle)`` from vertical, the soundings still stand at
    least ``min_height`` over the seabed (m), for edges facing ``directions`` ways (the first
    away from the sonar across the track, then turning toward the track ahead): the cones cast
    at the edge set ever farther from the axis and detected as the sonar does
    (:func:`mbinspect.beam.detect`).

    Examples
    --------
    >>> r = reach(Beam(beam_across_deg=1.0), 20.0, 0.8, 1.5, 18.0, directions=4)
    >>> bool(0.2 < r[1] < 0.36 and r[2] < 0.05)  # along: most of a footprint; toward the sonar: little
    True
    """
    beam = beam.replace(sub_rays=max(beam.sub_rays, FINE))  # the pattern near continuous
    angle = math.acos(min(max(cos_angle, 0.05), 1.0))
    axis = np.array([[math.sin(angle), 0.0, -math.cos(angle)]])
    a, b = frame(axis, np.array([[math.cos(angle), 0.0, math.sin(angle)]]))
    d = np.vstack([axis, cone_directions(beam, axis, a, b)])
    top = -rng * math.cos(angle)
    bed = top - height
    s = np.linspace(0.0, 1.2 * rng * beam.spread() / max(cos_angle, 0.2), 61)
    modes = np.repeat(beam.modes(np.array([angle])), len(s))
    half = window(beam, np.full(len(s), rng), np.full(len(s), cos_angle))
    out = np.zeros(directions)
    for k in range(directions):
        phi = 2 * math.pi * k / directions
        normal = np.array([math.cos(phi), math.sin(phi)])
        r, cos, reef = _edge_hits(normal, s, d, top, bed)
        strength = np.where(reef[:, 1:], 10 ** (contrast / 10), 1.0)
        energy = echo_energy(beam, strength.ravel(), cos[:, 1:].ravel()).reshape(len(s), -1)
        got = detect(r[:, 1:], energy, cos[:, 1:], beam, modes, half).range
        beyond = got * (d[0, :2] @ normal) - rng * (d[0, :2] @ normal) + s  # the sounding past the edge
        stands = np.isfinite(got) & (got * axis[0, 2] - bed >= min_height)
        out[k] = max(float(beyond[stands].max()), 0.0) if stands.any() else 0.0
    return out


def seen_from(points: np.ndarray, rows: np.ndarray, view: Sight
              ) -> tuple[float, float, tuple[float, float] | None, bool]:
    """A footprint's median range (m) and cosine of the beam angle; the plan unit vector
    pointing away from the sonar across the track (None when its soundings' pings are unknown
    or come from lines of several headings); whether they were all seen from that one side."""
    ray = points[rows] - view.origins[rows]
    rng = np.linalg.norm(ray, axis=1)
    cos = np.abs(ray[:, 2]) / np.maximum(rng, 1e-9)
    ax = view.axes[rows, :2]
    ok = np.isfinite(ax[:, 0])
    if ok.sum() < 0.5 * len(rows):
        return float(np.median(rng)), float(np.median(cos)), None, False
    # headings folded onto a half turn (a line sailed either way sees the same)
    ang = 2 * np.arctan2(ax[ok, 1], ax[ok, 0])
    c, s = float(np.mean(np.cos(ang))), float(np.mean(np.sin(ang)))
    if math.hypot(c, s) < 0.9:
        return float(np.median(rng)), float(np.median(cos)), None, False
    half = 0.5 * math.atan2(s, c)
    out = np.array([math.cos(half), math.sin(half)])
    side = np.sign(ray[ok, :2] @ out)
    share = float(np.mean(side > 0))
    if share < 0.5:
        out, share = -out, 1 - share
    return float(np.median(rng)), float(np.median(cos)), (float(out[0]), float(out[1])), share >= 0.8


def structure(reaches: np.ndarray, outward: tuple[float, float] | None, one_side: bool, cell: float
              ) -> np.ndarray:
    """The bloom's shape as a raster structuring element: the offsets within each edge
    direction's reach (:func:`reach`; the first away from the sonar), turned to the track
    (``outward``); each direction's and its mirror's larger where the reef was seen from both
    sides, a disc of the mean reach where the track's heading is unknown."""
    return Bloom.of(reaches, outward, one_side).structure(cell)


@dataclass(frozen=True, eq=False)
class Bloom:
    """How far past each edge of one footprint the beam's echo still stood on the reef: the
    reach (m) for :data:`DIRECTIONS` outward normals turned from ``outward`` (away from the
    sonar across the track) toward the track (:func:`reach`, ``raw``), at the median slant
    range ``rng`` of the soundings ``view`` saw; ``reaches`` with a mirror's larger taken
    where the footprint was seen from both sides, the mean every way where the heading is
    unknown (``outward`` then (1, 0))."""

    reaches: np.ndarray
    outward: tuple[float, float]
    raw: np.ndarray
    rng: float = 1.0
    view: Sight | None = None

    @classmethod
    def of(cls, raw: np.ndarray, outward: tuple[float, float] | None, one_side: bool, rng: float = 1.0,
           view: Sight | None = None) -> Bloom:
        n_dir = len(raw)
        reaches = raw
        if outward is None:
            reaches = np.full(n_dir, float(np.mean(raw)))
        elif not one_side:
            mirror = (n_dir // 2 - np.arange(n_dir)) % n_dir  # the same edge seen from the other side
            reaches = np.maximum(raw, raw[mirror])
        return cls(np.asarray(reaches, np.float64), outward or (1.0, 0.0), np.asarray(raw, np.float64), rng,
                   view)

    def grow(self, points: np.ndarray, rows: np.ndarray) -> Grow:
        """The bloom each of the soundings ``rows`` was heard with, by the outward normal of an
        edge (:class:`~mbinspect.reef_designs.Grow`): the footprint's reach as cast from the
        sounding's own side of the track (``raw``), in proportion to its slant range; the
        footprint's reach from both sides where its swath's axis is unknown."""
        n = len(rows)
        out = np.tile(np.array(self.outward, np.float64), (n, 1))
        if self.view is None:
            return Grow(self.reaches, out, np.ones(n))
        ray = points[rows] - self.view.origins[rows]
        factor = np.clip(np.linalg.norm(ray, axis=1) / max(self.rng, 1e-9), 0.5, 2.0)
        ax = self.view.axes[rows, :2]
        if not np.isfinite(ax[:, 0]).all():
            return Grow(self.reaches, out, factor)
        side = np.where(np.sum(ray[:, :2] * ax, axis=1) >= 0, 1.0, -1.0)
        out = ax * (side / np.maximum(np.hypot(ax[:, 0], ax[:, 1]), 1e-12))[:, None]
        return Grow(self.raw, out, factor)

    def structure(self, cell: float) -> np.ndarray:
        """The bloom's shape as a raster structuring element on cells of ``cell`` m."""
        n_dir = len(self.reaches)
        phis = 2 * np.pi * np.arange(n_dir) / n_dir
        n = int(math.ceil(float(self.reaches.max()) / cell))
        jj, ii = np.mgrid[-n:n + 1, -n:n + 1] * cell
        ox, oy = self.outward
        p, q = ii * ox + jj * oy, -ii * oy + jj * ox  # across (outward) and along the track
        out = np.ones(ii.shape, bool)
        for phi, r in zip(phis, self.reaches, strict=True):
            out &= p * math.cos(phi) + q * math.sin(phi) <= r + 1e-9
        out[n, n] = True
        return out


def _eroded(cells: np.ndarray, nx: int, se: np.ndarray) -> np.ndarray:
    """Which of a part's cells (flat indices in rows of ``nx``) stay once the part is closed and
    eroded by ``se``, a structuring element on cells :data:`SUB` times finer (a cell stays
    when at least half its sub-cells do)."""
    cj, ci = np.divmod(cells, nx)
    j0, i0 = int(cj.min()), int(ci.min())
    pad = -(-se.shape[0] // SUB)
    mask = np.zeros((int(cj.max()) - j0 + 1 + 2 * pad, int(ci.max()) - i0 + 1 + 2 * pad), bool)
    mask[cj - j0 + pad, ci - i0 + pad] = True
    fine = np.kron(mask, np.ones((SUB, SUB), bool))
    core = ndimage.binary_erosion(ndimage.binary_closing(fine, structure=se), structure=se)
    share = core.reshape(mask.shape[0], SUB, mask.shape[1], SUB).mean(axis=(1, 3))
    return share[cj - j0 + pad, ci - i0 + pad] >= 0.5


def unbloom_parts(points: np.ndarray, parts: list[np.ndarray], raster: Raster, is_reef: np.ndarray,
                  height: np.ndarray, view: Sight, *, min_height: float = 0.3
                  ) -> tuple[list[np.ndarray], Raster, list[Bloom | None]]:
    """Every part's footprint with its bloom taken off: eroded by the bloom's shape
    (:func:`reach`, :class:`Bloom`) at the part's range, beam angle, height and heading.
    Returns the parts' cells (flat raster indices), the raster with the bloom's cells
    unlabelled (and marked in its ``bloom``), and each part's bloom (None where none was cast)."""
    ny, nx = raster.labels.shape
    labels = raster.labels.copy()
    out: list[np.ndarray] = []
    blooms: list[Bloom | None] = []
    for cells in parts:
        rows = own_soundings(cells, raster, is_reef)
        if len(rows) < 3:
            out.append(cells)
            blooms.append(None)
            continue
        rng, cos, outward, one_side = seen_from(points, rows, view)
        tall = float(np.percentile(height[rows], 95))
        bloom = Bloom.of(reach(view.beam, rng, cos, tall, view.contrast_db, min_height=min_height),
                         outward, one_side, rng, view)
        blooms.append(bloom)
        keep = _eroded(cells, nx, bloom.structure(raster.cell / SUB))
        if not keep.any():
            out.append(cells)
            continue
        labels.ravel()[cells[~keep]] = 0
        out.append(cells[keep])
    bloomed = (labels == 0) & (raster.labels > 0)
    return out, Raster(raster.x0, raster.y0, raster.cell, labels, raster.nearest, bloomed), blooms


def heard_rows(points: np.ndarray, cells: np.ndarray, raster: Raster, is_reef: np.ndarray, bloom: Bloom,
               margin: int = 8) -> np.ndarray:
    """A part's reef soundings as the beam heard them: those nearest to its cells, and every
    other reef sounding within the bloom's reach of them (:func:`unbloom_parts`) that stands
    no nearer to another part (indices, sorted)."""
    own = own_soundings(cells, raster, is_reef)
    if raster.bloom is None:
        return own
    cj, ci = np.divmod(cells, raster.labels.shape[1])
    rows, cols = raster.window(cj, ci, margin)
    idx = soundings_around(raster, cj, ci, margin)
    idx = idx[is_reef[idx]]
    if not len(idx):
        return own
    mine = np.zeros((rows.stop - rows.start, cols.stop - cols.start), bool)
    mine[cj - rows.start, ci - cols.start] = True
    other = (raster.labels[rows, cols] > 0) & ~mine
    near = ndimage.distance_transform_edt(~mine) * raster.cell
    far = ndimage.distance_transform_edt(~other) * raster.cell if other.any() else np.full(mine.shape, np.inf)
    i, j = cell_index(points[idx], raster.x0, raster.y0, raster.cell)
    i, j = i - cols.start, j - rows.start
    ok = (i >= 0) & (i < mine.shape[1]) & (j >= 0) & (j < mine.shape[0])
    idx, i, j = idx[ok], i[ok], j[ok]
    keep = (near[j, i] <= far[j, i]) & (near[j, i] <= float(bloom.reaches.max()) + raster.cell)
    return np.union1d(own, idx[keep])
