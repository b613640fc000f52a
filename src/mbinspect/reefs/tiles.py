"""The reefs pipeline as the survey runner runs it (:class:`mbinspect.pipeline.Pipeline`)."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..cloud import PointCloud
from ..pipeline import TilePart
from .detect import STAT_BLOCK, STAT_REACH
from .footprint import SPACING_BLOCK, SPACING_REACH
from .group import number_reefs
from .options import ReefOptions
from .results import ReefResult
from .run import extract_reefs
from .score import score_reefs
from .split import AREA_RADIUS

__all__ = ["REEFS"]


@dataclass(frozen=True)
class ReefsPipeline:
    """Reefs: each tile extracts the reefs whose centre it owns (on the local seabed grid);
    the merge numbers and groups them once and scores them against the reference."""

    name: str = "reefs"
    options_class: type = ReefOptions

    def tile_fields(self, options: ReefOptions) -> tuple[str, ...]:
        """Pings (a reef seen by too few is set aside); told the beam, also the beam angles and
        intensities each ping's transducer and the reefs' echo contrast come from."""
        return ("ping", "beam_angle", "intensity") if options.beam_correction else ("ping",)

    def buffer(self, options: ReefOptions) -> float:
        """A reef's single-reef area comes from the parts within ``AREA_RADIUS`` m, each
        part's footprint from the sounding spacing within ``SPACING_REACH`` blocks, each
        sounding's height from the seabed window: the chain a tile must hold, plus the reef
        itself (and the reef points there from the statistical filter's blocks)."""
        reach = SPACING_BLOCK * (SPACING_REACH + 1) + STAT_BLOCK * (STAT_REACH + 1)
        return float(math.ceil(AREA_RADIUS + reach + options.seabed_window + 2 * options.noise_radius + 5.0))

    def grid_cell(self, options: ReefOptions) -> float:
        return float(options.seabed_cell)

    def tile_options(self, options: ReefOptions, extra: Mapping[str, Any]) -> tuple[ReefOptions, list[str]]:
        """The seabed ``auto`` (one plane where it fits the whole cloud) becomes the local
        grid: a tile does not see the whole cloud."""
        if options.seabed != "auto":
            return options, []
        return options.replace(seabed="grid"), [
            "tiled: the seabed is the local grid in every tile (`seabed` auto chooses one plane for a "
            "whole cloud, which a tile does not see)"]

    def run(self, cloud: PointCloud, options: ReefOptions, extra: Mapping[str, Any],
            progress: Callable[[float], None] | None = None) -> ReefResult:
        return extract_reefs(cloud, options, reference=extra.get("reference"), progress=progress,
                             times=extra.get("times"))

    def run_tile(self, cloud: PointCloud, options: ReefOptions, owns: Callable[[float, float], bool]
                 ) -> TilePart:
        r = extract_reefs(cloud, options)
        return TilePart(tuple(x for x in r.reefs if owns(x.x, x.y)),
                        tuple(o for o in r.others if owns(o.x, o.y)), {}, r.warnings,
                        {"seabed": r.seabed, "filters": r.filters,
                         "reef_area": r.footprint.get("reef_area_used")})

    def merge(self, parts: Sequence[TilePart], options: ReefOptions, extra: Mapping[str, Any],
              parameters: dict[str, Any], warnings: list[str]) -> ReefResult:
        reefs, groups = number_reefs([r for t in parts for r in t.objects], options.group_link)
        others = tuple(x for t in parts for x in t.others)
        evaluation, ref_xy = None, None
        reference = extra.get("reference")
        if reference is not None:
            evaluation, warn = score_reefs(reefs, reference, tolerance=options.tolerance)
            warnings += warn
            ref_xy = np.asarray(reference[0])
        seen = [t.stats for t in parts if "seabed" in t.stats]
        rms = [(s["seabed"].get("residual_rms"), s["n_own"]) for s in seen]
        rms = [(r, w) for r, w in rms if r is not None and np.isfinite(r)]
        weight = max(sum(w for _, w in rms), 1)
        mean = float(np.sqrt(sum(r * r * w for r, w in rms) / weight)) if rms else math.nan
        seabed = {"method": "local grid, per tile", "residual_rms": mean}
        removed = sum(s["filters"]["radius"]["n_removed"] for s in seen)
        filters = {"radius": {"n_removed_in_buffered_tiles": removed}}
        areas = np.array([s["reef_area"] for s in seen if s.get("reef_area") is not None], float)
        area = float(np.median(areas[np.isfinite(areas)])) if np.isfinite(areas).any() else math.nan
        return ReefResult(tuple(reefs), tuple(groups), others, seabed, filters, evaluation, parameters,
                          tuple(warnings), None, None, {"reef_area_used": area}, ref_xy)


REEFS = ReefsPipeline()
