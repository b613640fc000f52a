"""The pipelines the survey runner and the command line know, by name: a new pipeline is
one ``tiles.py`` meeting :class:`mbinspect.pipeline.Pipeline` and one row here.

A pipeline's package is imported when it is first named, not before: a reef run does not
pay for the piles' imports (SciPy's optimisers among them, 0.4-0.6 s) nor the other way.
"""

from __future__ import annotations

import importlib

from .errors import ParameterError
from .pipeline import Pipeline

__all__ = ["PIPELINES", "pipeline_named"]

#: Name -> the module and attribute that hold the pipeline.
PIPELINES: dict[str, tuple[str, str]] = {
    "piles": ("mbinspect.piles.tiles", "PILES"),
    "reefs": ("mbinspect.reefs.tiles", "REEFS"),
}


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
    >>> pipeline_named("reefs").name
    'reefs'
    """
    if not isinstance(name, str):
        return name
    if name not in PIPELINES:
        raise ParameterError(f"pipeline: {name!r}; expected one of {', '.join(PIPELINES)}", option="pipeline")
    module, attr = PIPELINES[name]
    pipeline: Pipeline = getattr(importlib.import_module(module), attr)
    return pipeline
