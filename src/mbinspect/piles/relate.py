"""The last stages of the pile pipeline, once every pile of a survey is measured: the
design, the jackets, the spacings, the levels and the frames (:func:`relate_piles`)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..io import PointCloud
from .assess import other_method_piles
from .design import Design
from .frame import fit_frames, leg_shims
from .group import group_piles
from .level import pile_levels
from .match import apply_design
from .options import PileOptions
from .radius import JointRadius
from .results import PileFit, PileResult, RejectedPile, Spacing
from .space import spacings

__all__ = ["relate_piles", "MeasuredPiles"]


@dataclass(frozen=True, eq=False)
class MeasuredPiles:
    """The piles of a cloud measured and judged, before design, grouping and spacing
    (:func:`measure_piles`); ``covs`` holds each pile's plan covariance by id."""

    piles: tuple[PileFit, ...]
    covs: dict[int, np.ndarray]
    rejected: tuple[RejectedPile, ...]
    warnings: tuple[str, ...]
    cloud: PointCloud
    segments: dict[int, Any] = field(default_factory=dict)
    seabed: Any = None
    cylinders: dict[int, Any] = field(default_factory=dict)
    segmentation: dict[str, Any] = field(default_factory=dict)
    iterations: tuple[dict[str, Any], ...] = ()
    joint_radius: JointRadius | None = None


def relate_piles(piles: Sequence[PileFit], covs: dict[int, np.ndarray], opts: PileOptions, *,
                 design: Design | None, parameters: dict[str, Any], warnings: list[str],
                 rejected: list[RejectedPile], measured: MeasuredPiles | None = None) -> PileResult:
    """The last stages of :func:`locate_piles`, once every pile of a survey is measured:
    matched to the design, grouped into jackets, every top's level (fitted with the lines'
    offsets), every spacing, level difference and frame with its legs' shims; on a tiled
    survey, after the tiles' piles are merged.

    Parameters
    ----------
    piles : sequence of PileFit
        Numbered from 1.
    covs : dict
        Plan covariance of each pile by id.
    opts : PileOptions
    design : Design or None
    parameters : dict
        What the result records.
    warnings : list of str
    rejected : list of dict
    measured : MeasuredPiles, optional
        The segments, seabed and cylinders, for figures (a whole-cloud run).
    """
    piles_t, remap, warn = apply_design(tuple(piles), design)
    piles_t = group_piles(piles_t, design, mode=opts.groups)
    # why a level is unknown or a lower bound is a warning where levels were asked for (a
    # design's tops, a clearance); otherwise each pile's record says it (its sigma, its note)
    asked = bool(design is not None and design.tops) or opts.min_clearance is not None
    piles_t, levels, level_notes = pile_levels(piles_t, design.tops if design is not None else {},
                                               tolerance=opts.level_tolerance,
                                               min_clearance=opts.min_clearance)
    covs = {remap[k]: v for k, v in covs.items()}
    pairs = spacings(piles_t, covs, design, opts.tolerance, all_pairs=opts.all_pairs,
                     method="centre" if opts.method == "centre" else "intersection")
    frames = fit_frames(piles_t, covs, design, tolerance=opts.frame_tolerance,
                        shims=leg_shims(piles_t, levels))
    others: tuple[PileFit, ...] = ()
    other_pairs: tuple[Spacing, ...] = ()
    if opts.method == "both":
        others, alt_covs, piles_t = other_method_piles(piles_t, opts.radius)
        other_pairs = spacings(others, alt_covs, design, opts.tolerance, method="centre",
                               all_pairs=opts.all_pairs)
    m = measured
    seg_info = m.segmentation if m is not None else {"intensity_threshold": {}, "piles": {}}
    return PileResult(piles_t, pairs, tuple(m.iterations if m else ()), parameters,
                      tuple(warnings + warn + (list(level_notes) if asked else [])),
                      {remap[k]: v for k, v in m.segments.items()} if m else {},
                      m.seabed if m else None,
                      {remap[k]: v for k, v in m.cylinders.items()} if m else {},
                      other_pairs, others,
                      {"intensity_threshold": {str(remap[k]): v
                                               for k, v in seg_info["intensity_threshold"].items()},
                       "piles": {str(remap[k]): v for k, v in seg_info["piles"].items()}},
                      frames, tuple(rejected), levels)


