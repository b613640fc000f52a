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

__all__ = ["PileModel", "BeamCorrection", "through_beam", "pile_models", "beam_contrast"]


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
        plan = np.hypot(pts[:, 0] - model.top[0], pts[:, 1] - model.top[1])
        local = np.flatnonzero(plan < reach)
        origins, axes, known = ping_geometry(pts[local], ping[local], beam_angle[local])
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
