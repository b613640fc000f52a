"""Stage 7 of the reefs: only reefs are reefs. Each rule looks at one measured candidate and
says why it is not a reef (a bump, a ridge, a design that fits only at another size or poorly,
a reef seen by too few pings, a dome), or None; the first reason given sets the candidate
aside among the others. A candidate that none of the designs given fits keeps its free-form
measures (a partial design list never hides a reef): its shape judges it.

A rule is ``(candidate, context, options) -> str | None``; a new rule is one function and one
entry in :data:`RULES`, as :mod:`mbinspect.piles.accept` is for piles.

Examples
--------
>>> from mbinspect.reefs.results import Reef
>>> from mbinspect.reefs.options import ReefOptions
>>> reef = Reef(1, 0.0, 0.0, -17.3, -17.1, 0.2, 9.0, 3.0, 3.0, 0.0, 1.8, 1.8, 500)
>>> why_not_a_reef(Candidate(reef, np.arange(9)), Context(np.zeros((0, 3))), ReefOptions())[:30]
'0.20 m above the seabed around'
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..grid import sounding_spacing
from .footprint import Raster
from .options import ReefOptions
from .results import OtherObject, Reef
from .shape import (
    DOME_PLATEAU,
    GroundSoundings,
    beam_weights,
    cell_soundings,
    dome_shape,
    line_levels,
    rounded_shape,
    thickness,
)

__all__ = ["Candidate", "Context", "Rule", "RULES", "why_not_a_reef", "other_object",
           "LOWEST_SHARE", "DESIGN_WITNESS_SCALE", "SHAPE_SOUNDINGS_ACROSS", "BLOOM_MISFIT"]

#: Least share of its design's height a reef fitted by that design shows above the seabed
#: (a cross of 1.2 m sunk 0.6 m still shows half).
LOWEST_SHARE = 0.4

#: A design fitted within this share of its size overrides the shape test for rocks (a
#: looser ``design_scale_tolerance``, for reefs built smaller, does not).
DESIGN_WITNESS_SCALE = 0.15

#: Soundings across a candidate's thickest part (:func:`~mbinspect.reefs.shape.thickness`)
#: below which its shape is not judged: a coarser grid blurs a flat top's edges into a dome
#: (a 0.5 m export of 3 m crosses with 1 m arms looks rounded).
SHAPE_SOUNDINGS_ACROSS = 6


#: Told the beam, a dome is also looked for in the footprint as heard (before its bloom was
#: taken off), its fit allowed this many times ``dome_misfit``: each sounding of the bloom
#: mixes the echoes of a cone over the curved surface and stands off it by more than the
#: noise (rocks at 25 m through 1° cones: misfit 0.08-0.18 of the height as heard,
#: 0.05-0.16 once eroded; the flat tops of cubes, hollow squares and crosses drop under
#: 0.15 of their height or misfit by over 0.16 either way).
BLOOM_MISFIT = 1.25


@dataclass(frozen=True)
class Candidate:
    """A measured footprint: the reef as measured and its flat raster cells; told the beam,
    also the cells as heard (``heard``: before its bloom was taken off)."""

    reef: Reef
    cells: np.ndarray
    heard: np.ndarray | None = None


@dataclass(frozen=True)
class Context:
    """What the rules may look at around a candidate.

    Attributes
    ----------
    points : ndarray, shape (N, 3)
        The soundings the footprints were made from.
    is_reef : ndarray of bool, shape (N,), optional
    raster : Raster, optional
        The footprint raster (cells -> nearest sounding).
    ping, line : ndarray of int, shape (N,), optional
        Each sounding's ping and survey line, when the file gives them.
    ground : GroundSoundings, optional
        The seabed soundings (:func:`~mbinspect.reefs.shape.ground_soundings`).
    reach : ndarray, shape (N,), optional
        Told the beam, how far each sounding's cone may sound it high or low
        (:func:`~mbinspect.reefs.shape.cone_reach`): its weight in a top's shape.
    """

    points: np.ndarray
    is_reef: np.ndarray | None = None
    raster: Raster | None = None
    ping: np.ndarray | None = None
    line: np.ndarray | None = None
    ground: GroundSoundings | None = None
    reach: np.ndarray | None = None


#: A rule: why a candidate is not a reef, or None.
Rule = Callable[[Candidate, Context, ReefOptions], "str | None"]


def too_low(c: Candidate, ctx: Context, options: ReefOptions) -> str | None:
    """Lower above the seabed around it than a reef point must stand."""
    if c.reef.height < options.min_height:
        return (f"{c.reef.height:.2f} m above the seabed around it (`min_height` {options.min_height:g} m): "
                "a bump of the seabed, not a reef")
    return None


def ridge(c: Candidate, ctx: Context, options: ReefOptions) -> str | None:
    """Much longer than wide: a sand-wave crest."""
    reef = c.reef
    elongation = reef.length / max(reef.width, 1e-9)
    if options.max_elongation and elongation > options.max_elongation:
        return (f"elongated ({reef.length:.1f} × {reef.width:.1f} m, {elongation:.1f} times longer than "
                f"wide; `max_elongation` {options.max_elongation:g}): a ridge such as a sand-wave crest, "
                "not a compact reef")
    return None


def design_misfit(c: Candidate, ctx: Context, options: ReefOptions) -> str | None:
    """The design fitted to it fits at another size, fits poorly, or stands far taller."""
    reef = c.reef
    design = next((d for d in options.designs if d.name == reef.design), None)
    if design is None:
        return None
    if abs(reef.design_scale - 1) > options.design_scale_tolerance:
        return (f"fits the {design.name} design only at {reef.design_scale:.2f} of its size "
                f"(`design_scale_tolerance` {options.design_scale_tolerance:g}): a rock or other object")
    if reef.design_misfit > options.design_misfit_max:
        return (f"fits the {design.name} design poorly ({reef.design_misfit:.0%} of its edge soundings "
                f"on the wrong side; `design_misfit_max` {options.design_misfit_max:g})")
    scale = reef.design_scale if reef.design_scale > 0 else 1.0
    tall = max(b.dz + b.height for b in design.boxes) * scale
    if reef.height < LOWEST_SHARE * tall:
        return (f"{reef.height:.2f} m high where the {design.name} design fitted to its plan is "
                f"{tall:.2f} m: not that design even if sunk (a reef shows at least "
                f"{LOWEST_SHARE:.0%} of its height)")
    return None


def few_pings(c: Candidate, ctx: Context, options: ReefOptions) -> str | None:
    """Seen by fewer than ``min_pings`` pings: its plan shape is unknown."""
    if ctx.ping is None or ctx.raster is None or ctx.is_reef is None:
        return None
    idx = cell_soundings(c.cells, ctx.raster)
    n = int(len(np.unique(ctx.ping[idx[ctx.is_reef[idx]]])))
    if n < options.min_pings:
        return (f"seen by {n} ping{'s' * (n != 1)} (`min_pings` {options.min_pings}): "
                "its plan shape is unknown")
    return None


def rock_shape(c: Candidate, ctx: Context, options: ReefOptions) -> str | None:
    """A dome or a rounded top: a rock, unless a design fits it at its size.

    Its surface is the elevation of each footprint cell's nearest sounding above the seabed
    at its centre (its surface by plan area, however many soundings its walls caught from
    oblique beams), each less its line's level (:func:`~mbinspect.reefs.shape.line_levels`).
    Not judged where too few soundings lie across it to show its top's edges
    (:data:`SHAPE_SOUNDINGS_ACROSS`). Told the beam (``c.heard``), the footprint as heard is
    judged too: a dome there within :data:`BLOOM_MISFIT` times ``dome_misfit`` is a rock,
    and so is a rounded top there when taking the bloom off left too little to judge (the
    reach of a straight edge's bloom takes a dome's flanks away, which have no edge to
    bloom from).
    """
    reef = c.reef
    # a design that fits at its size (with few edge soundings astray) is a stronger
    # witness than the shape of a top: a deeply sunk triangle's sloping faces look rounded
    if reef.design and abs(reef.design_scale - 1) <= DESIGN_WITNESS_SCALE:
        return None
    if not (options.rounded_spread or options.dome_misfit) or ctx.raster is None:
        return None
    shape = _surface_shape(c.cells, reef, ctx)
    why = _rock_reason(shape, options, options.dome_misfit, rounded=True) if shape else None
    if why or c.heard is None:
        return why
    heard = _surface_shape(c.heard, reef, ctx)
    why = _rock_reason(heard, options, BLOOM_MISFIT * options.dome_misfit, rounded=shape is None) \
        if heard else None
    return f"as heard through the beam, {why}" if why else None


def _surface_shape(cells: np.ndarray, reef: Reef, ctx: Context
                   ) -> tuple[float, float, float, float, float] | None:
    """The dome fit and the rounding of the footprint ``cells``' surface (misfit, drop,
    spread, plateau, width across), or None where too few soundings lie across it."""
    assert ctx.raster is not None
    points = ctx.points
    idx = cell_soundings(cells, ctx.raster)
    own = np.unique(idx)
    across = thickness(cells, ctx.raster)
    if len(own) < 10 or sounding_spacing(points[own]) > across / SHAPE_SOUNDINGS_ACROSS:
        return None
    z = points[idx, 2] - reef.z_seabed
    if ctx.line is not None and ctx.ground is not None:
        z = z - line_levels(points[idx], ctx.line[idx], ctx.ground)
    w = None if ctx.reach is None else beam_weights(ctx.reach[idx], reef.height)
    misfit, drop = dome_shape(points[idx, :2], z, across, w)
    spread, plateau = rounded_shape(z, w)
    return misfit, drop, spread, plateau, across


def _rock_reason(shape: tuple[float, float, float, float, float], options: ReefOptions,
                 dome_misfit: float, *, rounded: bool) -> str | None:
    """Why a surface of this shape (:func:`_surface_shape`) is a rock's, or None."""
    misfit, drop, spread, plateau, across = shape
    if 0 < options.dome_misfit and misfit <= dome_misfit and drop >= options.dome_drop \
            and plateau <= DOME_PLATEAU:
        allowed = f"`dome_misfit` {options.dome_misfit:g}{_times(dome_misfit, options.dome_misfit)}"
        return (f"a dome: its upper soundings fit a curved surface within {misfit:.0%} of its height "
                f"({allowed}) that drops {drop:.0%} of its height across half "
                f"its {across:.1f} m width (`dome_drop` {options.dome_drop:g}), with {plateau:.0%} of it "
                "near its top: a rock, not a reef")
    if rounded and spread >= options.rounded_spread > 0 and plateau <= options.rounded_plateau:
        return (f"rounded: its highest soundings spread over {spread:.0%} of its height (`rounded_spread` "
                f"{options.rounded_spread:g}) and {plateau:.0%} lie near its top (`rounded_plateau` "
                f"{options.rounded_plateau:g}): a rock, not a reef's flat top")
    return None


def _times(allowed: float, option: float) -> str:
    return f" × {allowed / option:g} as heard" if allowed != option else ""


#: The rules, in the order their reasons are given.
RULES: tuple[Rule, ...] = (too_low, ridge, design_misfit, few_pings, rock_shape)


def why_not_a_reef(candidate: Candidate, context: Context, options: ReefOptions,
                   rules: tuple[Rule, ...] = RULES) -> str | None:
    """The first reason a rule gives why ``candidate`` is not a reef, or None.

    Parameters
    ----------
    candidate : Candidate
        A measured footprint.
    context : Context
        The soundings and raster around it.
    options : ReefOptions
    rules : tuple of Rule
        The rules to apply, in order (default :data:`RULES`).

    Returns
    -------
    str or None
    """
    for rule in rules:
        why = rule(candidate, context, options)
        if why:
            return why
    return None


def other_object(reef: Reef, reason: str) -> OtherObject:
    """An object that is not a reef, as a result's ``others`` lists it.

    Parameters
    ----------
    reef : Reef
        The candidate as measured.
    reason : str

    Returns
    -------
    OtherObject
    """
    return OtherObject(reef.x, reef.y, reef.height, reef.area, reef.z_top, reef.n_points, reason, reef.least)
