"""Extract, separate, measure and score artificial reefs, after Shen et al. and past it.

The pipeline, one module per stage (:func:`extract_reefs` in ``run`` calls them in order):

1. ``detect`` - :func:`denoise`: the paper's radius filter on every sounding.
2. ``terrain`` - :func:`screen_terrain` with :func:`rough_terrain`: steep, rough terrain
   (the paper cut the uneven near-shore area away by hand) judged on the robust local
   seabed and excluded.
3. ``ground`` - :func:`fit_seabed`: the paper's RANSAC plane (0.5 m, N from
   ln(1-q)/ln(1-P^K), P learnt) where one plane fits, else a robust local grid surface.
4. ``detect`` - :func:`reef_points`: height above the local seabed over a core threshold,
   plus the lower parts connected to a core (hysteresis); :func:`clean_reef_points`.
5. ``footprint`` and ``split`` - :func:`nearest_label_raster`, :func:`label_parts` and
   :func:`split_reefs`: a plan raster labelled by its nearest sounding, its parts joined
   or split into single reefs; parts smaller than ``min_area`` are other objects.
6. ``measure`` - :func:`measure_reef`: centre, seabed and top elevation, height, area,
   minimum-area rectangle, outline, volumes, point count; ``fit_design`` -
   :func:`fit_reef_design` and its companions when the deployed designs are known.
7. ``group`` - :func:`number_reefs`: reading-order ids and groups.
8. ``score`` - :func:`score_reefs` against a reference list.

``paper`` holds the paper's plain method (:func:`paper_clusters`), run with
``method="paper"``. Every option is declared once in :class:`ReefOptions`.

Examples
--------
>>> from mbinspect.simulate import simulate
>>> from mbinspect.reefs import extract_reefs
>>> sim = simulate("reef-field", seed=1, groups="cross1", ping_spacing=0.8)
>>> result = extract_reefs(sim.cloud)
>>> len(result.reefs)
25
"""

from .detect import clean_reef_points, denoise, reef_points
from .fit_design import fit_reef_design, join_by_design, share_by_design, with_design
from .footprint import Raster, label_parts, nearest_label_raster
from .ground import Seabed, fit_seabed
from .group import group_reefs, number_reefs
from .measure import measure_reef, outline, own_soundings, ring_seabed, soundings_around
from .options import REEF_METHODS, ReefOptions
from .paper import paper_clusters
from .results import Reef, ReefResult
from .run import extract_reefs
from .score import score_reefs
from .single import single_reefs
from .split import diameter, local_reef_area, merge_fragments, row_ends, split_large, split_reefs
from .terrain import Ground, TerrainMask, rough_terrain, screen_terrain

__all__ = [
    "REEF_METHODS",
    "ReefOptions",
    "Reef",
    "ReefResult",
    "Seabed",
    "TerrainMask",
    "Ground",
    "rough_terrain",
    "screen_terrain",
    "denoise",
    "fit_seabed",
    "reef_points",
    "clean_reef_points",
    "Raster",
    "nearest_label_raster",
    "label_parts",
    "split_reefs",
    "split_large",
    "local_reef_area",
    "merge_fragments",
    "row_ends",
    "diameter",
    "measure_reef",
    "outline",
    "own_soundings",
    "soundings_around",
    "ring_seabed",
    "fit_reef_design",
    "join_by_design",
    "share_by_design",
    "with_design",
    "group_reefs",
    "number_reefs",
    "score_reefs",
    "paper_clusters",
    "single_reefs",
    "extract_reefs",
]
