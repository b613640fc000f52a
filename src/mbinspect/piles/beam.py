"""Stage 5b: piles seen through the beam (issue 28).

A sonar's beam is a cone: its echo mixes whatever lies within it, so a wall's soundings move
along their beams (the curved wall heard behind its face near normal incidence, in front of it
towards the silhouette) and the steel's echo, heard at the edge of a cone whose axis misses the
pile, puts soundings in the water beside the walls and the top. Every line makes the same
error, so the jackknife cannot see it.

After a first measurement, each pile's model (its fitted cylinder and top, the seabed around
it) is looked at through the survey's own beams: every sounding near the pile is cast again as
its beam's cone at the model (:mod:`mbinspect.beam`: the same sub-rays and detection as the
simulator's) and compared with where its thin axis meets the model. The difference is the
beam's bias for that sounding:

- a sounding whose axis meets the pile and whose strongest echo is the pile's moves back
  along its beam by it;
- a sounding whose strongest echo is the pile's though its axis misses it (a bloom beside a
  wall, a wing beside the top) is left out;
- a sounding the seabed's echo still makes stays as it is.

The pile is then measured again from the corrected soundings (each time from the soundings
as read, the bias taken from the newer model, until no centre moves by a millimetre:
:func:`mbinspect.piles.run.measure_piles`). Each sounding's ray runs from its
ping's transducer (:func:`mbinspect.pings.ping_geometry`), so the survey must keep the ping
and beam angle of each sounding (the sonar formats and LAS do); the steel's echo is taken to be
``contrast_db`` above the seabed's, measured from the soundings' intensity where they have
one.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

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
from ..fit import Cylinder
from ..geometry import ray_cylinder
from ..pings import ping_geometry
from .results import PileFit

__all__ = ["PileModel", "BeamCorrection", "through_beam", "top_through_beam", "pile_models", "beam_contrast"]


@dataclass(frozen=True)
class PileModel:
    """A measured pile as the beam sees it: top centre, unit axis (up), radius, and the
    seabed level around it."""

    top: np.ndarray
    axis: np.ndarray
    radius: float
    seabed_z: float


@dataclass(frozen=True, eq=False)
class BeamCorrection:
    """The soundings corrected for the beam: new coordinates, which to keep, counts, and per
    model half the footprint of the beams that reach it (m: median range × tan(width) / 2),
    the scale of what the beam blurs where the model itself is uncertain."""

    points: np.ndarray
    keep: np.ndarray
    moved: int
    left_out: int
    half_footprints: tuple[float, ...] = ()


def through_beam(points: np.ndarray, ping: np.ndarray, beam_angle: np.ndarray, models: list[PileModel],
                 beam: Beam, *, reach: float, contrast_db: float = DEFAULT_CONTRAST_DB) -> BeamCorrection:
    """Each sounding near a modelled pile corrected for its beam (see the module's notes).

    Each pile's soundings are placed on their rays by their pings' soundings within
    ``reach`` of it only (:func:`mbinspect.pings.ping_geometry`), so a pile in one tile of a
    survey, which holds that much around it (:attr:`PileOptions.neighbourhood`), is corrected
    as in the whole survey.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
        The soundings as read.
    ping : ndarray of int, shape (N,)
        Each sounding's ping, unique across the survey (:func:`mbinspect.pings.ping_keys`).
    beam_angle : ndarray, shape (N,)
        Degrees from vertical (the detection changes with it).
    models : list of PileModel
    beam : Beam
        The survey's beam widths and detection.
    reach : float
        The neighbourhood of each pile whose soundings place the beams (m).
    contrast_db : float
        The pile's echo over the seabed's (dB).

    Returns
    -------
    BeamCorrection
    """
    pts = np.asarray(points, np.float64)
    out = pts.copy()
    keep = np.ones(len(pts), bool)
    moved = 0
    halves = []
    for model in models:
        local, origins, axes, known = _placed(pts, ping, beam_angle, model, reach)
        sel = _near(pts[local], origins, known, model, beam)
        halves.append(0.0)
        if not len(sel):
            continue
        rows, o = local[sel], origins[sel]
        ray = pts[rows] - o
        length = np.linalg.norm(ray, axis=1)
        halves[-1] = float(np.median(length)) * math.tan(max(beam.widths())) / 2
        d = ray / length[:, None]
        seen = _cast(model, beam, o, d, axes[sel], np.radians(beam_angle[rows]), contrast_db)
        shift = seen.on_pile & seen.axis_on_pile & np.isfinite(seen.bias)
        out[rows[shift]] -= seen.bias[shift, None] * d[shift]
        keep[rows[seen.on_pile & ~seen.axis_on_pile]] = False
        moved += int(shift.sum())
    return BeamCorrection(out, keep, moved, int((~keep).sum()), tuple(halves))


def _near(pts: np.ndarray, origins: np.ndarray, known: np.ndarray, model: PileModel, beam: Beam
          ) -> np.ndarray:
    """The soundings (of ``pts``) whose cone may meet the pile: placed on a ray, within the
    cone's reach of its plan circle (at the sounding's own range), above the seabed's metre
    below."""
    rng = np.linalg.norm(pts - np.where(known[:, None], origins, pts), axis=1)
    plan = np.hypot(pts[:, 0] - model.top[0], pts[:, 1] - model.top[1])
    reach = model.radius + rng * beam.spread() + 0.5
    return np.flatnonzero(known & (plan < reach) & (pts[:, 2] > model.seabed_z - 1.0))


def _placed(pts: np.ndarray, ping: np.ndarray, beam_angle: np.ndarray, model: PileModel, reach: float
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The soundings within ``reach`` of a pile (rows of ``pts``), each one's transducer and
    swath axis from its ping's seabed soundings there (:func:`_on_seabed`), and which have one."""
    local = np.flatnonzero(np.hypot(pts[:, 0] - model.top[0], pts[:, 1] - model.top[1]) < reach)
    origins, axes, known = ping_geometry(pts[local], ping[local], beam_angle[local],
                                         fit=_on_seabed(pts[local, 2], model))
    return local, origins, axes, known


def _on_seabed(z: np.ndarray, model: PileModel) -> np.ndarray:
    """The soundings at the seabed's level round a pile (within 0.3 m of it, or a quarter of
    the pile's height): those its pings' transducers are placed from."""
    return z < model.seabed_z + min(0.3, 0.25 * (float(model.top[2]) - model.seabed_z))


@dataclass(frozen=True)
class _Seen:
    bias: np.ndarray
    on_pile: np.ndarray
    axis_on_pile: np.ndarray


def _hits(model: PileModel, o: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each ray's first hit on the model: range, whether on the pile, surface normal."""
    length = (float(model.top[2]) - model.seabed_z + 1.0) / max(float(model.axis[2]), 1e-6)
    tc, nc = ray_cylinder(model.top, model.axis, model.radius, length, o, d)
    with np.errstate(divide="ignore", invalid="ignore"):
        ts = np.where(d[:, 2] < -1e-9, (model.seabed_z - o[:, 2]) / d[:, 2], np.inf)
    pile = tc < ts
    normal = np.where(pile[:, None], nc, np.array([0.0, 0.0, 1.0]))
    return np.where(pile, tc, ts), pile, normal


def _cast(model: PileModel, beam: Beam, o: np.ndarray, d: np.ndarray, across: np.ndarray, angle: np.ndarray,
          contrast_db: float) -> _Seen:
    s = beam.sub_rays**2
    t_axis, axis_pile, _ = _hits(model, o, d)
    a, b = frame(d, across)
    dirs = cone_directions(beam, d, a, b)
    t, pile, normal = _hits(model, np.repeat(o, s, axis=0), dirs)
    cos_inc = np.clip(-np.einsum("ij,ij->i", dirs, normal), 0.0, 1.0)
    energy = echo_energy(beam, np.where(pile, 10 ** (contrast_db / 10), 1.0), cos_inc)
    r_seabed = (model.seabed_z - o[:, 2]) / np.minimum(d[:, 2], -1e-9)
    half = window(beam, r_seabed, np.clip(-d[:, 2], 0.0, 1.0))
    shape = (len(o), s)
    det = detect(np.where(np.isfinite(t), t, np.nan).reshape(shape), energy.reshape(shape),
                 cos_inc.reshape(shape), beam, beam.modes(angle), half)
    on_pile = pile.reshape(shape)[np.arange(len(o)), det.strongest] & np.isfinite(det.range)
    return _Seen(det.range - t_axis, on_pile, axis_pile)


def pile_models(piles: Sequence[PileFit], cylinders: dict[int, Cylinder], pts: np.ndarray) -> list[PileModel]:
    """Each measured pile as the beam sees it: its top centre, its cylinder's axis (plumb
    without one), its radius, and the seabed's level around it (the 30th percentile of the
    soundings 1 to 4 m out from its wall: under the blooms the beam puts beside it)."""
    models = []
    for p in piles:
        cyl = cylinders.get(p.id)
        axis = np.array([0.0, 0.0, 1.0]) if cyl is None else np.asarray(cyl.axis, float)
        plan = np.hypot(pts[:, 0] - p.x, pts[:, 1] - p.y)
        ring = (plan > p.radius + 1.0) & (plan < p.radius + 4.0) & (pts[:, 2] < p.z)
        seabed = float(np.percentile(pts[ring, 2], 30)) if ring.sum() >= 10 else p.z - 5.0
        models.append(PileModel(np.array([p.x, p.y, p.z]), axis, p.radius, seabed))
    return models


def beam_contrast(intensity: np.ndarray | None, pts: np.ndarray, piles: Sequence[PileFit]) -> float:
    """The piles' echo over the seabed's (dB): the median intensity (dB) of the soundings on
    their walls over that of the seabed 1 to 4 m out (:func:`~mbinspect.beam.echo_contrast_db`);
    :data:`~mbinspect.beam.DEFAULT_CONTRAST_DB` without intensities."""
    if intensity is None or not piles:
        return DEFAULT_CONTRAST_DB
    on, off = np.zeros(len(pts), bool), np.zeros(len(pts), bool)
    for p in piles:
        plan = np.hypot(pts[:, 0] - p.x, pts[:, 1] - p.y)
        on |= (np.abs(plan - p.radius) < 0.1) & (pts[:, 2] < p.z - 0.2)
        off |= (plan > p.radius + 1.0) & (plan < p.radius + 4.0)
    return echo_contrast_db(intensity[on], intensity[off])


#: Ping blocks of the jackknife that gives a top's centre through the beam its covariance.
TOP_BLOCKS = 8

#: The centre search for a top seen through the beam: a coarse grid (half-width, step) about
#: the first centre, then a fine one about the coarse grid's best (m).
TOP_COARSE, TOP_FINE = (0.2, 0.02), (0.03, 0.0025)

#: How well the steel's contrast over the seabed is known (dB, 1-sigma): what it moves a
#: top's centre fitted through the beam joins the centre's covariance.
TOP_CONTRAST_SIGMA_DB = 2.0


def top_through_beam(points: np.ndarray, ping: np.ndarray, beam_angle: np.ndarray, model: PileModel,
                     beam: Beam, *, reach: float, contrast_db: float = DEFAULT_CONTRAST_DB
                     ) -> tuple[np.ndarray, np.ndarray] | None:
    """The plan centre of a top no wall sounding shows, fitted to what its beams returned.

    Through a cone, a beam whose cone takes in part of the top hears the steel's echo louder
    than the seabed's once the pattern's weight on the top, times the contrast, outweighs
    its weight on the seabed (the detection follows the louder window of echoes): the top is
    heard as a disc grown by the footprint, and the soundings at its level stand on their
    beams' axes, off the steel (the wings). So the centre is the one for which each beam near
    the top is predicted as it was heard: at the top's level, or on the seabed (a sounding
    between the two is the wall's echo, which says nothing of the top's edge). Each beam's
    sub-rays are carried to the top's plane; the centres of a grid about the first are
    counted by the beams they mispredict, and the centre is the mean of the best, weighted
    by ``exp(-(count - fewest))``. The covariance is a jackknife over :data:`TOP_BLOCKS`
    blocks of pings, each from the same counts, plus what the contrast's own uncertainty
    (:data:`TOP_CONTRAST_SIGMA_DB`) moves the centre.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
        The soundings as read (the wings are what this fit reads).
    ping, beam_angle : ndarray, shape (N,)
        Each sounding's ping key and beam angle (degrees).
    model : PileModel
        The pile as first measured: its top centre and level, radius, seabed.
    beam : Beam
    reach : float
        The neighbourhood whose soundings place the beams (m).
    contrast_db : float
        The steel's echo over the seabed's (dB).

    Returns
    -------
    (centre (2,), covariance (2, 2)) or None
        None where too few beams near the top are placed, or too few hear its level.
    """
    pts = np.asarray(points, np.float64)
    local, origins, axes, known = _placed(pts, ping, beam_angle, model, reach)
    rng = np.linalg.norm(pts[local] - np.where(known[:, None], origins, pts[local]), axis=1)
    height = float(model.top[2]) - model.seabed_z
    z = pts[local, 2]
    top = z > model.top[2] - min(0.15, 0.25 * height)
    sel = np.flatnonzero(known & (top | _on_seabed(z, model)) & (origins[:, 2] > model.top[2]))
    hits = _on_top_plane(origins[sel], pts[local[sel]], axes[sel], beam, float(model.top[2]))
    # the beams whose cones cross the top's plane near its edge (a beam past the far rim
    # sounds the seabed in the pile's shadow, well beyond it)
    gap = np.hypot(hits[..., 0] - model.top[0], hits[..., 1] - model.top[1]).min(axis=1) - model.radius
    near = gap < 2 * TOP_COARSE[0] + rng[sel] * beam.spread()
    sel, hits = sel[near], hits[near]
    if len(sel) < 20 or top[sel].sum() < 5:
        return None
    _, block = np.unique(ping[local[sel]], return_inverse=True)
    block = block.ravel() * TOP_BLOCKS // (block.max() + 1)
    fits = [_top_centres(hits, top[sel], block, beam.grid()[2], contrast_db + dc, model)
            for dc in (0.0, -TOP_CONTRAST_SIGMA_DB, TOP_CONTRAST_SIGMA_DB)]
    centre, parts = fits[0]
    if len(parts) < 3:
        return None
    dev = np.array(parts) - np.mean(parts, axis=0)
    contrast = (fits[2][0] - fits[1][0]) / 2  # one sigma of the contrast's effect
    return centre, (len(parts) - 1) / len(parts) * dev.T @ dev + np.outer(contrast, contrast)


def _top_centres(hits: np.ndarray, heard: np.ndarray, block: np.ndarray, pattern: np.ndarray,
                 contrast_db: float, model: PileModel) -> tuple[np.ndarray, list[np.ndarray]]:
    """The centre from every beam, and from all but each block of pings in turn."""
    contrast = 10 ** (contrast_db / 10)
    grid = _grid(np.asarray(model.top[:2], float), *TOP_COARSE)
    miss = _mispredicted(grid, hits, heard, pattern, contrast, model.radius)
    grid = _grid(grid[int(np.argmin(miss.sum(axis=1)))], *TOP_FINE)
    miss = _mispredicted(grid, hits, heard, pattern, contrast, model.radius)
    return _best(grid, miss.sum(axis=1)), [_best(grid, miss[:, block != g].sum(axis=1))
                                           for g in range(TOP_BLOCKS) if (block == g).any()]


def _on_top_plane(origins: np.ndarray, pts: np.ndarray, axes: np.ndarray, beam: Beam, z: float
                  ) -> np.ndarray:
    """Where each beam's sub-rays cross the plane of the top, (B, S, 2)."""
    ray = pts - origins
    d = ray / np.linalg.norm(ray, axis=1, keepdims=True)
    a, b = frame(d, axes)
    dirs = cone_directions(beam, d, a, b).reshape(len(d), -1, 3)
    t = (z - origins[:, None, 2]) / np.minimum(dirs[..., 2], -1e-9)
    return origins[:, None, :2] + t[..., None] * dirs[..., :2]


def _grid(centre: np.ndarray, half: float, step: float) -> np.ndarray:
    """Plan points every ``step`` within ``half`` of ``centre`` both ways, (K, 2)."""
    k = np.arange(-half, half + step / 2, step)
    return centre + np.stack(np.meshgrid(k, k), axis=-1).reshape(-1, 2)


def _mispredicted(centres: np.ndarray, hits: np.ndarray, heard: np.ndarray, pattern: np.ndarray,
                  contrast: float, radius: float) -> np.ndarray:
    """For each candidate centre and beam, whether the beam is mispredicted, (K, B): heard at
    the top's level though the pattern's weight on the disc times the steel's ``contrast``
    (linear) is under its weight on the seabed, or the other way round."""
    out = np.empty((len(centres), len(hits)), bool)
    for i in range(0, len(centres), 64):
        c = centres[i:i + 64]
        on = np.hypot(hits[None, :, :, 0] - c[:, None, None, 0],
                      hits[None, :, :, 1] - c[:, None, None, 1]) <= radius  # (k, B, S)
        steel = on @ pattern
        out[i:i + 64] = (contrast * steel > pattern.sum() - steel) != heard[None, :]
    return out


def _best(centres: np.ndarray, count: np.ndarray) -> np.ndarray:
    """The mean of the candidate centres, each weighted by ``exp(-(count - fewest))``."""
    w = np.exp(-(count - count.min()).astype(float))
    return (w[:, None] * centres).sum(axis=0) / w.sum()
