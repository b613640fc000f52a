"""A reef design as solid boxes in any orientation: upright, upside down or on either side,
tilted and placed; and the upper surface each orientation shows a sonar from above.

The simulator builds overturned and tilted units from these boxes, and the reef chain
compares what it sounded with each orientation's upper surface
(:mod:`mbinspect.reefs.orient`): the same geometry on both sides.

Examples
--------
>>> from mbinspect.reef_designs import BUILTIN_DESIGNS
>>> d = BUILTIN_DESIGNS["cross1"]
>>> [round(float(max(c[:, 2].max() for c in corners(design_solids(d, o)))), 2)
...  for o in ("upright", "on its side")]
[1.2, 3.0]
>>> distinct_orientations(BUILTIN_DESIGNS["cube"])
('upright',)
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import lru_cache

import numpy as np

from .errors import ParameterError
from .geometry import bearing_to_vector
from .reef_designs import ReefDesign
from .solids import box_corners, turn, upper_surface

__all__ = ["ORIENTATIONS", "Solid", "design_solids", "corners", "surface_map", "sample",
           "distinct_orientations"]

#: The ways a unit can come to rest: a turn of the design about its own axes.
ORIENTATIONS: dict[str, np.ndarray] = {
    "upright": np.eye(3),
    "upside down": turn((1.0, 0.0, 0.0), 180.0),
    "on its side": turn((1.0, 0.0, 0.0), 90.0),
    "on its other side": turn((0.0, 1.0, 0.0), 90.0),
}

#: A box as :mod:`mbinspect.solids` takes it: base centre, axes as rows, (length, width, height).
Solid = tuple[np.ndarray, np.ndarray, tuple[float, float, float]]


def _box_frame(bearing_deg: float) -> np.ndarray:
    u = bearing_to_vector(bearing_deg)
    return np.array([[u[0], u[1], 0.0], [u[1], -u[0], 0.0], [0.0, 0.0, 1.0]])


def corners(solids: Sequence[Solid]) -> list[np.ndarray]:
    """Each box's eight corners (8, 3)."""
    return [box_corners(*s) for s in solids]


def _moved(solids: list[Solid], rot: np.ndarray, shift: np.ndarray) -> list[Solid]:
    return [(rot @ b + shift, a @ rot.T, size) for b, a, size in solids]


def _rest(solids: list[Solid], centre: bool) -> list[Solid]:
    """Lifted so that the lowest corner is at z = 0; with ``centre``, the centre of mass
    (of the boxes' volumes) over the origin."""
    c = np.concatenate(corners(solids))
    shift = np.array([0.0, 0.0, -c[:, 2].min()])
    if centre:
        vol = np.array([size[0] * size[1] * size[2] for _, _, size in solids])
        mid = np.array([b + a[2] * size[2] / 2 for b, a, size in solids])
        shift[:2] = -(vol @ mid[:, :2]) / vol.sum()
    return _moved(solids, np.eye(3), shift)


def design_solids(design: ReefDesign, orientation: str = "upright", x: float = 0.0, y: float = 0.0,
                  bearing_deg: float = 0.0, z_base: float = 0.0, scale: float = 1.0,
                  tilt_deg: float = 0.0, tilt_bearing_deg: float = 0.0) -> list[Solid]:
    """The design's boxes at rest in an orientation, tilted and placed.

    Parameters
    ----------
    design : ReefDesign
    orientation : str
        A key of :data:`ORIENTATIONS`.
    x, y, bearing_deg : float
        Plan position of the design's centre (m) and its bearing (degrees clockwise).
    z_base : float
        Elevation of the lowest corner (m).
    scale : float
        As built relative to the design.
    tilt_deg, tilt_bearing_deg : float
        The unit leans by ``tilt_deg`` toward ``tilt_bearing_deg`` (resting on a rock or
        on its own edge in soft ground); it rests on its lowest corner.

    Returns
    -------
    list of (base, axes, size)
    """
    if orientation not in ORIENTATIONS:
        raise ParameterError(f"orientation {orientation!r}; expected one of {', '.join(ORIENTATIONS)}")
    solids: list[Solid] = [(np.array([b.dx, b.dy, b.dz]) * scale, _box_frame(b.bearing_deg),
                            (b.length * scale, b.width * scale, b.height * scale)) for b in design.boxes]
    if orientation != "upright":
        solids = _rest(_moved(solids, ORIENTATIONS[orientation], np.zeros(3)), centre=True)
    if tilt_deg:
        h = bearing_to_vector(tilt_bearing_deg)
        solids = _rest(_moved(solids, turn((-h[1], h[0], 0.0), tilt_deg), np.zeros(3)), centre=False)
    return _moved(solids, turn((0.0, 0.0, 1.0), -bearing_deg), np.array([x, y, z_base]))


@lru_cache(maxsize=256)
def surface_map(design: ReefDesign, orientation: str, cell: float = 0.02, bloom: float = 0.0
                ) -> tuple[np.ndarray, float, float]:
    """The upper surface of the design at rest in ``orientation`` (bearing 0, scale 1) on a
    ``cell`` m grid centred on the design's centre: heights (n, n) (0 where no box stands),
    the grid's first node (x0 = y0) and its cell.

    ``bloom`` (m, whole cells): the surface as a beam whose cone has that radius hears it,
    each point the highest within the cone round it (sampled at half and the whole radius
    in 12 directions): a top's edge heard beyond it, as the bloom of a finite beam puts it.

    Examples
    --------
    >>> from mbinspect.reef_designs import BUILTIN_DESIGNS
    >>> h, g0, c = surface_map(BUILTIN_DESIGNS["cube"], "upright")
    >>> hb, gb, _ = surface_map(BUILTIN_DESIGNS["cube"], "upright", bloom=0.2)
    >>> round(float((h > 0).sum() * c * c), 2), round(float((hb > 0).sum() * c * c), 2)
    (3.92, 5.61)
    """
    if bloom > 0:
        h, g0, _ = surface_map(design, orientation, cell)
        pad = int(math.ceil(bloom / cell))
        h = np.pad(h, pad)
        out = h.copy()
        n = len(h)
        for f in (0.5, 1.0):
            for t in np.linspace(0.0, 2 * math.pi, 12, endpoint=False):
                di, dj = (int(round(f * bloom * v / cell)) for v in (math.sin(t), math.cos(t)))
                # out[j, i] = max(out, h[j + dj, i + di]) where that lies on the map
                src = h[max(dj, 0): n + min(dj, 0), max(di, 0): n + min(di, 0)]
                dst = out[max(-dj, 0): n + min(-dj, 0), max(-di, 0): n + min(-di, 0)]
                np.maximum(dst, src, out=dst)
        return out, g0 - pad * cell, cell
    solids = design_solids(design, orientation)
    reach = max(float(np.abs(c[:, :2]).max()) for c in corners(solids)) + 2 * cell
    n = 2 * int(math.ceil(reach / cell)) + 1
    g = (np.arange(n) - (n - 1) / 2) * cell
    xx, yy = np.meshgrid(g, g)
    h = upper_surface(solids, np.column_stack([xx.ravel(), yy.ravel()])).reshape(n, n)
    return np.where(np.isfinite(h), h, 0.0), float(g[0]), cell


def sample(design: ReefDesign, orientation: str, xy: np.ndarray, x: float | np.ndarray,
           y: float | np.ndarray, bearing_deg: float | np.ndarray, scale: float = 1.0, *,
           bloom: float = 0.0) -> np.ndarray:
    """The upper surface of the design in ``orientation`` placed at (x, y, bearing, scale),
    at plan points (N, 2) (nearest node of :func:`surface_map`): heights above its base,
    (N,); or, given K poses (``x``, ``y``, ``bearing_deg`` arrays of K), (K, N). ``bloom``:
    as a beam whose cone has that radius (m) hears it (:func:`surface_map`, to 2 cm)."""
    h, g0, cell = surface_map(design, orientation, 0.02, round(bloom / scale / 0.02) * 0.02)
    many = np.ndim(bearing_deg) > 0
    b = np.radians(np.atleast_1d(np.asarray(bearing_deg, np.float64)))[:, None]
    c, s = np.cos(b), np.sin(b)
    rx = (xy[None, :, 0] - np.atleast_1d(np.asarray(x, np.float64))[:, None]) / scale
    ry = (xy[None, :, 1] - np.atleast_1d(np.asarray(y, np.float64))[:, None]) / scale
    # into the design frame: turn counter-clockwise by the bearing
    n = h.shape[0]
    i = np.rint(((rx * c - ry * s) - g0) / cell).astype(np.intp)
    j = np.rint(((rx * s + ry * c) - g0) / cell).astype(np.intp)
    ok = (i >= 0) & (i < n) & (j >= 0) & (j < n)
    out = np.where(ok, h[np.clip(j, 0, n - 1), np.clip(i, 0, n - 1)] * scale, 0.0)
    return out if many else out[0]


@lru_cache(maxsize=64)
def distinct_orientations(design: ReefDesign, tolerance: float = 0.15) -> tuple[str, ...]:
    """The orientations of ``design`` that look different from above: each one's upper
    surface differs from every earlier one's at every bearing (1° steps) by more than
    ``tolerance`` × the design's height (RMS over a grid that covers both). A solid cube
    has one; a double-layer cross tells upside down from upright."""
    reach = max(-surface_map(design, name)[1] for name in ORIENTATIONS)
    g = np.arange(-reach, reach + 1e-9, 0.08)
    xx, yy = np.meshgrid(g, g)
    xy = np.column_stack([xx.ravel(), yy.ravel()])
    kept: list[str] = []
    for name in ORIENTATIONS:
        mine = sample(design, name, xy, 0.0, 0.0, 0.0)
        same = any(min(float(np.sqrt(np.mean((sample(design, k, xy, 0.0, 0.0, b) - mine) ** 2)))
                       for b in np.arange(0.0, 360.0, 1.0)) <= tolerance * design.height for k in kept)
        if not same:
            kept.append(name)
    return tuple(kept)
