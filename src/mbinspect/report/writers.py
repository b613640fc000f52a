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
from functools import partial
from pathlib import Path
from typing import Any

from ..forked import forked
from ..outputs import atomic_path, write_json, write_table
from .gis import write_gis

__all__ = ["Outputs", "Writer", "WRITERS", "NEED_FIGURES", "figure_job", "write_outputs"]


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
        ``figures(folder) -> [job, ...]``: the drawing jobs, each ``job() -> {name: png
        bytes}`` drawing and saving one or more figures into the folder. They are
        independent: :func:`write_outputs` runs them in forked processes
        (:mod:`mbinspect.forked`) while it writes the tables.
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
    figures: Callable[[Path], Sequence[Callable[[], dict[str, bytes]]]] | None = None
    figure_file: Callable[[str], str] = lambda name: f"{name}.png"
    page: Callable[[dict[str, bytes]], str] | None = None
    layers: tuple[tuple[str, list[dict[str, Any]]], ...] = ()


def _draw_one(name: str, draw: Callable[..., bytes], args: tuple[Any, ...]) -> dict[str, bytes]:
    return {name: draw(*args)}


def figure_job(name: str, draw: Callable[..., bytes], *args: Any) -> Callable[[], dict[str, bytes]]:
    """A drawing job of :attr:`Outputs.figures`: ``draw(*args)`` (which saves one figure and
    returns its PNG bytes) as ``{name: png}``."""
    return partial(_draw_one, name, draw, args)


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


#: Writer name -> writer, in the order they run. The figures are drawn meanwhile, in other
#: processes; a writer of :data:`NEED_FIGURES` waits for them (the page inlines them).
WRITERS: dict[str, Writer] = {"json": _json, "csv": _csv, "geojson": _geojson, "figures": _figures,
                              "html": _html}

#: The writers that need the drawn figures.
NEED_FIGURES = frozenset({"figures", "html"})


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
    jobs = outputs.figures(out) if figures and outputs.figures is not None else []
    written: list[str] = []
    with forked(jobs) as drawn:
        images: dict[str, bytes] | None = None  # until a writer needs them
        for name in writers:
            if name in NEED_FIGURES and images is None:
                images = {n: png for part in drawn() for n, png in part.items()}
            written += WRITERS[name](outputs, out, images or {})
    return written
