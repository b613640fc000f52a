"""One table of output writers, fed by one function per pipeline that builds what they write.

A pipeline turns its result into :class:`Outputs` (``report.piles.pile_outputs``,
``report.reefs.reef_outputs``): the record (``to_dict()``), its tables, its map features,
its figures and its report page. Each writer of :data:`WRITERS` writes one kind of file from
it; a new output (a shapefile, a GeoPackage layer) is one function and one row here, and
every pipeline gets it.

Examples
--------
>>> import tempfile
>>> o = Outputs("things", {"things": [{"id": 1, "x": 0.5}]},
...             tables=(("things.csv", [{"id": 1, "x": 0.5}], ["id", "x"]),))
>>> write_outputs(o, Path(tempfile.mkdtemp()), writers=("json", "csv"))
['things.json', 'things.csv']
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..outputs import atomic_path, write_json, write_table
from .gis import write_gis

__all__ = ["Outputs", "Writer", "WRITERS", "write_outputs"]


@dataclass(frozen=True)
class Outputs:
    """What one result gives the writers.

    Attributes
    ----------
    stem : str
        The files' stem (``piles`` -> ``piles.json``, ``piles.geojson``).
    record : mapping
        The result's ``to_dict()``: the JSON file, exactly.
    tables : tuple of (file name, rows, columns)
        The CSV tables.
    features : list of dict
        GeoJSON features in the survey's CRS.
    crs : str, optional
        The survey's CRS.
    figures : callable, optional
        ``figures(folder) -> {name: png bytes}``: draws and saves the figures.
    figure_file : callable
        A figure's name -> its file name.
    page : callable, optional
        ``page(images) -> str``: the report page, the figures inlined.
    layers : tuple of (stem, features)
        More GeoJSON layers, each in its own files (``<stem>.geojson`` and projected).
    """

    stem: str
    record: Mapping[str, Any]
    tables: tuple[tuple[str, Sequence[Mapping[str, Any]], Sequence[str]], ...] = ()
    features: list[dict[str, Any]] = field(default_factory=list)
    crs: str | None = None
    figures: Callable[[Path], dict[str, bytes]] | None = None
    figure_file: Callable[[str], str] = lambda name: f"{name}.png"
    page: Callable[[dict[str, bytes]], str] | None = None
    layers: tuple[tuple[str, list[dict[str, Any]]], ...] = ()


#: A writer: ``(outputs, folder, images) -> names of the files written``.
Writer = Callable[[Outputs, Path, dict[str, bytes]], list[str]]


def _json(o: Outputs, out: Path, images: dict[str, bytes]) -> list[str]:
    write_json(o.record, out / f"{o.stem}.json")
    return [f"{o.stem}.json"]


def _csv(o: Outputs, out: Path, images: dict[str, bytes]) -> list[str]:
    for name, rows, columns in o.tables:
        write_table(rows, out / name, columns)
    return [name for name, _, _ in o.tables]


def _geojson(o: Outputs, out: Path, images: dict[str, bytes]) -> list[str]:
    return write_gis(o.features, o.crs, out, o.stem) + [
        name for stem, features in o.layers for name in write_gis(features, o.crs, out, stem)]


def _figures(o: Outputs, out: Path, images: dict[str, bytes]) -> list[str]:
    return [o.figure_file(n) for n in images]


def _html(o: Outputs, out: Path, images: dict[str, bytes]) -> list[str]:
    if o.page is None:
        return []
    with atomic_path(out / "report.html") as tmp:
        tmp.write_text(o.page(images), encoding="utf-8")
    return ["report.html"]


#: Writer name -> writer, in the order they run (the figures are drawn before any runs, so
#: that the page can inline them).
WRITERS: dict[str, Writer] = {"json": _json, "csv": _csv, "geojson": _geojson, "figures": _figures,
                              "html": _html}


def write_outputs(outputs: Outputs, out: str | Path, *, figures: bool = True,
                  writers: Sequence[str] = tuple(WRITERS)) -> list[str]:
    """Write a result's files into ``out`` (a staging folder of :func:`mbinspect.outputs.output_dir`).

    Parameters
    ----------
    outputs : Outputs
    out : path
    figures : bool
        Draw the figures (the slowest output).
    writers : sequence of str
        Names in :data:`WRITERS`, all by default.

    Returns
    -------
    list of str
        The files written, in order.
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    images = outputs.figures(out) if figures and outputs.figures is not None else {}
    written: list[str] = []
    for name in writers:
        written += WRITERS[name](outputs, out, images)
    return written
