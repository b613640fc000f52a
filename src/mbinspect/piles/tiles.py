"""The piles pipeline as the survey runner runs it (:class:`mbinspect.pipeline.Pipeline`)."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..cloud import PointCloud
from ..errors import DataError
from ..pipeline import TilePart
from .design import searched_tilt
from .options import PileOptions
from .results import PileFit, PileResult
from .run import locate_piles, measure_piles, no_pile_found, relate_piles
from .separate import stable_order

__all__ = ["PILES"]


@dataclass(frozen=True)
class PilesPipeline:
    """Piles: each tile measures the piles whose centre it owns; the merge renumbers them
    as one cloud numbers them and relates them once (design, jackets, spacings, frames)."""

    name: str = "piles"
    options_class: type = PileOptions

    def tile_fields(self, options: PileOptions) -> tuple[str, ...]:
        """Pings, intensities and beam angles: the backscatter threshold and the beam."""
        return ("ping", "intensity", "beam_angle")

    def buffer(self, options: PileOptions) -> float:
        """A pile's neighbourhood and a metre (:attr:`PileOptions.neighbourhood`)."""
        return float(math.ceil(options.neighbourhood + 1.0))

    def grid_cell(self, options: PileOptions) -> float:
        return float(options.seabed_cell)

    def tile_options(self, options: PileOptions, extra: Mapping[str, Any]) -> tuple[PileOptions, list[str]]:
        """``count`` is checked after the merge, not in each tile; tilts are searched beyond
        the design's rake (:func:`~mbinspect.piles.design.searched_tilt`), as a whole run
        searches them."""
        options = searched_tilt(options, extra.get("design"))
        return (options.replace(count=None) if options.count is not None else options), []

    def run(self, cloud: PointCloud, options: PileOptions, extra: Mapping[str, Any],
            progress: Callable[[float], None] | None = None) -> PileResult:
        return locate_piles(cloud, options, design=extra.get("design"), progress=progress)

    def run_tile(self, cloud: PointCloud, options: PileOptions, owns: Callable[[float, float], bool]
                 ) -> TilePart:
        m = measure_piles(cloud, options)
        keep = tuple(p for p in m.piles if owns(p.x, p.y))
        rejected = tuple(o for o in m.rejected if owns(o.x, o.y))
        return TilePart(keep, rejected, {p.id: m.covs[p.id] for p in keep}, m.warnings)

    def merge(self, parts: Sequence[TilePart], options: PileOptions, extra: Mapping[str, Any],
              parameters: dict[str, Any], warnings: list[str]) -> PileResult:
        piles: list[tuple[PileFit, np.ndarray]] = [(p, t.extra[p.id]) for t in parts for p in t.objects]
        order = stable_order(np.array([[p.x, p.y] for p, _ in piles])) if piles else np.zeros(0, int)
        covs: dict[int, np.ndarray] = {}
        renamed: list[PileFit] = []
        for k in order:  # numbered as one cloud numbers them: rows south to north, west to east
            p, cov = piles[int(k)]
            covs[len(renamed) + 1] = cov
            renamed.append(replace(p, id=len(renamed) + 1))
        if not piles:  # the answer a whole run gives: the candidates each tile owns
            raise DataError(no_pile_found([r for t in parts for r in t.others]))
        if options.count is not None and len(piles) != options.count:
            warnings.append(f"{len(piles)} piles found where `count` says {options.count}")
        rejected = [r for t in parts for r in t.others]
        return relate_piles(renamed, covs, options, design=extra.get("design"), parameters=parameters,
                            warnings=warnings, rejected=rejected)


PILES = PilesPipeline()
