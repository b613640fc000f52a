"""Locate underwater piles and every pile spacing, after Xia & Zhang (2022) and past it.

The pipeline, one module per stage (:func:`locate_piles` in ``run`` calls them in order):

1. ``elevate`` - :func:`elevated_points`: a robust local seabed and the points standing well
   above it, lone water-column returns removed; :func:`intensity_threshold` between
   structure and seabed.
2. ``separate`` - :func:`separate_piles`: K-means with k-means++ seeding when the count is
   known (the paper), connected components otherwise; :func:`stable_order` of the ids.
3. ``split`` - :func:`split_top_side`: the joint threshold segmentation (the paper's sliding
   elevation window, local normals and a backscatter threshold) of each pile.
4. ``centre`` and ``intersect`` - :func:`centre_method` (mean of the top points within
   r + k_s) and :func:`intersection_method` (MSAC cylinder on the side, least squares on
   true orthogonal distances, the axis met with the top plane; tilt and its bearing).
5. ``measure`` and ``iterate`` - :func:`measure_pile` by the chosen method and
   :func:`prune` to the fitted models, repeated by :func:`iterate` until every spacing
   changes by less than ``delta``.
6. ``assess`` - :func:`assess_pile`: the flags of a pile whose data cannot support a
   centimetre answer.
7. ``design``, ``group`` and ``space`` - :func:`apply_design` (design ids),
   :func:`group_piles` (jackets, from the design's groups or the spacing) and
   :func:`spacings` within each jacket with their 1-sigma and the design's verdict at 95 %.
8. ``frame`` - :func:`fit_frames`: each jacket's design frame fitted to its measured
   centres (rigid, weighted), each pile's miss with its 1-sigma, and the frame's verdict.

Every option is declared once in :class:`PileOptions`. Pile ids are stable: rows from
south to north, and west to east within a row; with a design of positions, the design's
ids (one-to-one nearest matching).

Examples
--------
>>> from mbinspect.simulate import simulate
>>> from mbinspect.piles import locate_piles
>>> sim = simulate("jacket", seed=2, ping_spacing=0.25)
>>> result = locate_piles(sim.cloud, count=4, radius=0.75)
>>> [p.id for p in result.piles]
[1, 2, 3, 4]
"""

from .assess import assess_pile, other_method_piles
from .centre import centre_method, top_coverage
from .design import Design, read_design
from .elevate import elevated_points, intensity_threshold, pile_thresholds
from .frame import decide, fit_frames
from .group import group_piles, jacket_groups
from .intersect import intersection_method, side_coverage
from .iterate import iterate
from .match import apply_design, match_design
from .measure import measure_pile, prune
from .options import METHODS, PileOptions
from .results import FrameFit, PileFit, PileMeasure, PileResult, PileSegment, Spacing
from .run import locate_piles
from .separate import separate_piles, stable_order
from .space import spacings
from .split import segment_piles, split_top_side

__all__ = [
    "METHODS",
    "PileOptions",
    "Design",
    "read_design",
    "match_design",
    "apply_design",
    "PileSegment",
    "PileMeasure",
    "PileFit",
    "Spacing",
    "PileResult",
    "elevated_points",
    "intensity_threshold",
    "pile_thresholds",
    "separate_piles",
    "stable_order",
    "split_top_side",
    "segment_piles",
    "centre_method",
    "top_coverage",
    "intersection_method",
    "side_coverage",
    "measure_pile",
    "prune",
    "iterate",
    "assess_pile",
    "other_method_piles",
    "spacings",
    "group_piles",
    "jacket_groups",
    "fit_frames",
    "decide",
    "FrameFit",
    "locate_piles",
]
