"""What a pipeline declares so that the survey runner can run it whole or in tiles,
without knowing which pipeline it runs.

A pipeline (``piles/tiles.py``, ``reefs/tiles.py``) is a small object meeting
:class:`Pipeline`; :mod:`mbinspect.pipelines` lists them by name. The runner reads the
survey, asks the pipeline for its tile buffer and the fields it reads, runs each tile
through :meth:`Pipeline.run_tile` (the objects whose centre the tile owns, as a
:class:`TilePart`) and hands the parts to :meth:`Pipeline.merge` once.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

from .cloud import PointCloud

__all__ = ["Pipeline", "TilePart"]


@dataclass(frozen=True)
class TilePart:
    """What one tile gives the merge.

    Attributes
    ----------
    objects : tuple
        The objects whose centre lies in the tile's own square.
    others : tuple
        The objects set aside (not reefs, not measurable piles) that the tile owns.
    extra : mapping
        Per-object data the merge needs, by the object's id in the tile (a pile's plan
        covariance).
    warnings : tuple of str
    stats : mapping
        What the tile saw (its seabed, its filters), for the merged result.
    """

    objects: tuple[Any, ...] = ()
    others: tuple[Any, ...] = ()
    extra: Mapping[Any, Any] = field(default_factory=dict)
    warnings: tuple[str, ...] = ()
    stats: Mapping[str, Any] = field(default_factory=dict)


class Pipeline(Protocol):
    """A pipeline as the survey runner sees it.

    Attributes
    ----------
    name : str
        Its name in :data:`mbinspect.pipelines.PIPELINES` and in progress lines.
    options_class : type
        The frozen options dataclass it runs with.
    """

    @property
    def name(self) -> str: ...

    @property
    def options_class(self) -> type: ...

    def tile_fields(self, options: Any) -> tuple[str, ...]:
        """The per-sounding fields it reads besides x, y, z, ``file`` and ``line`` with these
        options: all a tile keeps of the survey's fields."""
        ...

    def buffer(self, options: Any) -> float:
        """Metres a tile reads beyond its square, so that every stage sees near the edge
        what it sees inside."""
        ...

    def grid_cell(self, options: Any) -> float:
        """The plan cell (m) of the largest grid it builds (the survey's memory test)."""
        ...

    def tile_options(self, options: Any, extra: Mapping[str, Any]) -> tuple[Any, list[str]]:
        """The options each tile runs with (``extra`` as :meth:`run` takes it), and why they
        differ from those given."""
        ...

    def run(self, cloud: PointCloud, options: Any, extra: Mapping[str, Any],
            progress: Callable[[float], None] | None = None) -> Any:
        """The result of the whole cloud in one piece."""
        ...

    def run_tile(self, cloud: PointCloud, options: Any, owns: Callable[[float, float], bool]) -> TilePart:
        """One tile's part: ``owns(x, y)`` says whether the tile owns a point."""
        ...

    def merge(self, parts: Sequence[TilePart], options: Any, extra: Mapping[str, Any],
              parameters: dict[str, Any], warnings: list[str]) -> Any:
        """The tiles' parts as one result, numbered, grouped and scored once."""
        ...
