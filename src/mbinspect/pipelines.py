"""The pipelines the survey runner and the command line know, by name: a new pipeline is
one ``tiles.py`` meeting :class:`mbinspect.pipeline.Pipeline` and one row here."""

from __future__ import annotations

from .errors import ParameterError
from .piles.tiles import PILES
from .pipeline import Pipeline
from .reefs.tiles import REEFS

__all__ = ["PIPELINES", "pipeline_named"]

#: Name -> pipeline.
PIPELINES: dict[str, Pipeline] = {p.name: p for p in (PILES, REEFS)}


def pipeline_named(name: str | Pipeline) -> Pipeline:
    """The pipeline called ``name`` (a pipeline is returned as it is).

    Parameters
    ----------
    name : str or Pipeline

    Returns
    -------
    Pipeline

    Examples
    --------
    >>> pipeline_named("reefs").fields
    ('ping',)
    """
    if not isinstance(name, str):
        return name
    if name not in PIPELINES:
        raise ParameterError(f"pipeline: {name!r}; expected one of {', '.join(PIPELINES)}", option="pipeline")
    return PIPELINES[name]
