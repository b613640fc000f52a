"""One writer for what ``simulate`` and ``inject`` leave in their folder: the soundings,
``truth.json``, ``labels.npz`` and the tables a pipeline takes (``design.csv`` for piles,
``reference.csv`` for reefs)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..cloud import PointCloud
from ..io import write
from ..outputs import write_json, write_table

__all__ = ["write_bundle"]


def write_bundle(folder: Path, truth: Mapping[str, Any], *, cloud: PointCloud | None = None,
                 cloud_name: str = "soundings.npz", labels: np.ndarray | None = None,
                 ident: np.ndarray | None = None,
                 reference: Sequence[tuple[float, float, Any]] | None = None) -> list[str]:
    """Write a simulated or injected survey's files into ``folder``.

    Parameters
    ----------
    folder : Path
        The (staging) output folder.
    truth : mapping
        ``truth.json``; its ``design`` rows (piles) become ``design.csv``, its ``tide``
        rows (a simulated tide gauge) ``tide.csv``.
    cloud : PointCloud, optional
        The soundings, written as ``cloud_name`` (its extension picks the format).
    cloud_name : str
    labels, ident : ndarray, optional
        Each sounding's truth label and object id (``labels.npz``).
    reference : sequence of (x, y, id), optional
        The reefs' reference positions (``reference.csv``).

    Returns
    -------
    list of str
        The names of the files written.

    Examples
    --------
    >>> import tempfile
    >>> write_bundle(Path(tempfile.mkdtemp()), {"design": [{"id": 1, "x": 0.0, "y": 0.0}]})
    ['truth.json', 'design.csv']
    """
    written = []
    if cloud is not None:
        write(cloud, folder / cloud_name)
        written.append(cloud_name)
    write_json(dict(truth), folder / "truth.json")
    written.append("truth.json")
    if labels is not None:
        np.savez_compressed(folder / "labels.npz", label=labels,
                            ident=ident if ident is not None else np.zeros_like(labels))
        written.append("labels.npz")
    design = truth.get("design")
    if design:
        cols = [c for c in ("group", "id", "x", "y", "top", "tilt_deg", "tilt_azimuth_deg") if c in design[0]]
        write_table(list(design), folder / "design.csv", cols)
        written.append("design.csv")
    if truth.get("plan"):
        write_table([{k: ("" if v is None else v) for k, v in u.items()} for u in truth["plan"]],
                    folder / "plan.csv", ["id", "x", "y", "bearing_deg", "kind"])
        written.append("plan.csv")
    if truth.get("tide"):
        write_table(list(truth["tide"]), folder / "tide.csv", ["time", "height"])
        written.append("tide.csv")
    if reference:
        write_table([{"x": x, "y": y, "id": i} for x, y, i in reference], folder / "reference.csv",
                    ["x", "y", "id"])
        written.append("reference.csv")
    return written
