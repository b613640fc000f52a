"""A site register that grows: every survey of a site, every unit with its history and every
change, in one GeoPackage (an SQLite file QGIS and GDAL open as it is).

Written with the standard library's ``sqlite3`` and the GeoPackage 1.3 tables done as the
standard says (``gpkg_spatial_ref_sys``, ``gpkg_contents``, ``gpkg_geometry_columns``,
geometries as GeoPackage binary headers over little-endian WKB); the tests read it back with
GDAL (pyogrio). Layers:

* ``surveys`` (attributes): each survey added, its result file and that file's sha256;
* ``objects`` (points): each unit of the site with its own id, where it was last seen and
  whether it is still there;
* ``observations`` (points): each unit in each survey, as that survey's result measured it;
* ``changes`` (lines from before to after, in the before survey's frame): each unit's change
  between two surveys with its 95 % levels of detection.

A register is changed on a copy that replaces it only when complete.
"""

from __future__ import annotations

import datetime as dt
import json
import math
import shutil
import sqlite3
import struct
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from ..errors import InputError
from ..outputs import atomic_path
from ..piles.results import PileResult
from ..reefs.results import ReefResult
from .results import MEASURES, ChangeResult

__all__ = ["register_change", "last_two", "history", "point_blob", "line_blob"]

#: GeoPackage's application id ('GPKG') and version (1.3.0).
APPLICATION_ID, USER_VERSION = 0x47504B47, 10300

_SRS = """CREATE TABLE gpkg_spatial_ref_sys (srs_name TEXT NOT NULL, srs_id INTEGER PRIMARY KEY,
 organization TEXT NOT NULL, organization_coordsys_id INTEGER NOT NULL, definition TEXT NOT NULL,
 description TEXT)"""
_CONTENTS = """CREATE TABLE gpkg_contents (table_name TEXT NOT NULL PRIMARY KEY, data_type TEXT NOT NULL,
 identifier TEXT UNIQUE, description TEXT DEFAULT '',
 last_change DATETIME NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ','now')),
 min_x DOUBLE, min_y DOUBLE, max_x DOUBLE, max_y DOUBLE, srs_id INTEGER,
 CONSTRAINT fk_gc_r_srs_id FOREIGN KEY (srs_id) REFERENCES gpkg_spatial_ref_sys(srs_id))"""
_GEOMETRY_COLUMNS = """CREATE TABLE gpkg_geometry_columns (table_name TEXT NOT NULL,
 column_name TEXT NOT NULL, geometry_type_name TEXT NOT NULL, srs_id INTEGER NOT NULL, z TINYINT NOT NULL,
 m TINYINT NOT NULL, CONSTRAINT pk_geom_cols PRIMARY KEY (table_name, column_name),
 CONSTRAINT uk_gc_table_name UNIQUE (table_name),
 CONSTRAINT fk_gc_tn FOREIGN KEY (table_name) REFERENCES gpkg_contents(table_name),
 CONSTRAINT fk_gc_srs FOREIGN KEY (srs_id) REFERENCES gpkg_spatial_ref_sys (srs_id))"""


def _cols(text: str, kind: str = "DOUBLE") -> tuple[tuple[str, str], ...]:
    """Columns named in ``text`` (``name`` or ``name:TYPE``), of ``kind`` unless typed."""
    return tuple((c.split(":")[0], c.split(":")[1].replace("_", " ") if ":" in c else kind)
                 for c in text.split())


#: Each layer: (geometry type or None for attributes, its columns with their SQL types).
LAYERS: dict[str, tuple[str | None, tuple[tuple[str, str], ...]]] = {
    "surveys": (None, _cols("survey:INTEGER_UNIQUE_NOT_NULL result:TEXT result_sha256:TEXT sources:TEXT "
                            "added:TEXT kind:TEXT objects:INTEGER vertical_reference:TEXT dx dy dz")),
    "objects": ("POINT", _cols("object:INTEGER_UNIQUE_NOT_NULL design:TEXT first_survey:INTEGER "
                               "last_survey:INTEGER status:TEXT x y")),
    "observations": ("POINT", _cols("object:INTEGER_NOT_NULL survey:INTEGER_NOT_NULL result_id:INTEGER "
                                    "x y z_top height least_depth least_depth_tvu95 design:TEXT "
                                    "design_bearing_deg top_tilt_deg overturned:TEXT")),
    "changes": ("LINESTRING", _cols("object:INTEGER_NOT_NULL survey_before:INTEGER survey_after:INTEGER "
                                    "status:TEXT detected:TEXT")
                + tuple((c, "DOUBLE") for m, _, _ in MEASURES for c in (m, f"{m}_lod95"))),
}


def point_blob(x: float, y: float, srs_id: int) -> bytes:
    """A point as GeoPackage binary: the 'GP' header (version 0, little-endian, no envelope),
    the SRS id, then WKB.

    Examples
    --------
    >>> point_blob(1.0, 2.0, 4326)[:8].hex()
    '47500001e6100000'
    """
    return b"GP\x00\x01" + struct.pack("<i", srs_id) + struct.pack("<BIdd", 1, 1, x, y)


def line_blob(xy: list[tuple[float, float]], srs_id: int) -> bytes:
    """A line string as GeoPackage binary."""
    body = struct.pack("<BII", 1, 2, len(xy)) + b"".join(struct.pack("<dd", x, y) for x, y in xy)
    return b"GP\x00\x01" + struct.pack("<i", srs_id) + body


def _srs(crs: str | None) -> tuple[int, str, str]:
    """The register's SRS: (id, name, WKT) from the survey's CRS (EPSG when it has a code)."""
    if not crs:
        return -1, "Undefined cartesian SRS", "undefined"
    from pyproj import CRS

    c = CRS.from_user_input(crs)
    epsg = c.to_epsg()
    return (epsg if epsg is not None else 100000), c.name, c.to_wkt()


def _create(con: sqlite3.Connection, crs: str | None) -> int:
    """The GeoPackage's own tables and the register's layers; the SRS id."""
    con.execute(f"PRAGMA application_id = {APPLICATION_ID}")
    con.execute(f"PRAGMA user_version = {USER_VERSION}")
    for sql in (_SRS, _CONTENTS, _GEOMETRY_COLUMNS):
        con.execute(sql)
    srs_id, name, wkt = _srs(crs)
    rows = [("Undefined cartesian SRS", -1, "NONE", -1, "undefined", "undefined cartesian SRS"),
            ("Undefined geographic SRS", 0, "NONE", 0, "undefined", "undefined geographic SRS")]
    if srs_id != 4326:  # the standard asks for WGS 84 in every GeoPackage
        rows.append(("WGS 84 geodetic", 4326, "EPSG", 4326, _srs("EPSG:4326")[2], "longitude/latitude"))
    if srs_id > 0:
        rows.append((name, srs_id, "EPSG" if srs_id < 100000 else "NONE", srs_id, wkt, "the surveys' CRS"))
    con.executemany("INSERT INTO gpkg_spatial_ref_sys VALUES (?, ?, ?, ?, ?, ?)", rows)
    for table, (geom, cols) in LAYERS.items():
        columns = ", ".join(f"{c} {t}" for c, t in cols)
        if geom is None:
            con.execute(f"CREATE TABLE {table} (fid INTEGER PRIMARY KEY AUTOINCREMENT, {columns})")
            con.execute("INSERT INTO gpkg_contents (table_name, data_type, identifier) "
                        "VALUES (?, 'attributes', ?)", (table, table))
        else:
            con.execute(f"CREATE TABLE {table} (fid INTEGER PRIMARY KEY AUTOINCREMENT, geom {geom}, "
                        f"{columns})")
            con.execute("INSERT INTO gpkg_contents (table_name, data_type, identifier, srs_id) "
                        "VALUES (?, 'features', ?, ?)", (table, table, srs_id))
            con.execute("INSERT INTO gpkg_geometry_columns VALUES (?, 'geom', ?, ?, 0, 0)",
                        (table, geom, srs_id))
    return srs_id


@contextmanager
def _opened(path: Path, crs: str | None) -> Iterator[tuple[sqlite3.Connection, int]]:
    """The register (created when new) on a copy that replaces it when the block ends well."""
    with atomic_path(path) as tmp:
        if path.exists():
            shutil.copyfile(path, tmp)
        con = sqlite3.connect(tmp)
        try:
            if path.exists():
                _check(con, path)
                srs_id = int(con.execute("SELECT srs_id FROM gpkg_contents WHERE table_name = 'objects'")
                             .fetchone()[0])
            else:
                srs_id = _create(con, crs)
            yield con, srs_id
            con.execute("UPDATE gpkg_contents SET last_change = strftime('%Y-%m-%dT%H:%M:%fZ','now')")
            _extents(con)
            con.commit()
        finally:
            con.close()


def _check(con: sqlite3.Connection, path: Path) -> None:
    try:
        tables = {r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
    except sqlite3.DatabaseError:
        raise InputError(f"{path}: not a GeoPackage (not an SQLite file); expected a site register "
                         "mbinspect wrote") from None
    missing = sorted(set(LAYERS) - tables)
    if missing:
        raise InputError(f"{path}: a GeoPackage without the layer {missing[0]!r}; expected a site register "
                         "mbinspect wrote")


def _extents(con: sqlite3.Connection) -> None:
    """Each feature layer's bounds in ``gpkg_contents`` (from its x, y columns or its lines)."""
    for table, (geom, cols) in LAYERS.items():
        if geom is None or "x" not in dict(cols):
            continue
        row = con.execute(f"SELECT min(x), min(y), max(x), max(y) FROM {table}").fetchone()
        con.execute("UPDATE gpkg_contents SET min_x = ?, min_y = ?, max_x = ?, max_y = ? "
                    "WHERE table_name = ?", (*row, table))


def _sha(path: Path) -> str:
    from ..io import sha256_of

    return sha256_of(path)


def _result_file(path: str | Path) -> Path:
    p = Path(path)
    if p.is_dir():
        return p / "piles.json" if (p / "piles.json").is_file() and not (p / "reefs.json").is_file() \
            else p / "reefs.json"
    return p


def register_change(path: str | Path, change: ChangeResult, before: ReefResult | PileResult,
                    after: ReefResult | PileResult, *,
                    before_path: str | Path, after_path: str | Path, crs: str | None) -> dict[str, int]:
    """Add a comparison to the register at ``path``: the before survey (when the register is
    new), the after survey, each unit's observation, and the changes.

    The before survey must be the register's last one (surveys are added in order).

    Returns
    -------
    dict
        ``survey_before``, ``survey_after`` (their numbers in the register), ``objects``.

    Raises
    ------
    InputError
        A file that is no register, or a before survey that is not its last survey.
    """
    p = Path(path)
    bfile, afile = _result_file(before_path), _result_file(after_path)
    with _opened(p, crs) as (con, srs):
        last = con.execute("SELECT survey, result, result_sha256 FROM surveys "
                           "ORDER BY survey DESC LIMIT 1").fetchone()
        if last is None:
            sb = _add_survey(con, before, bfile, None)
            ids = {r.id: _new_object(con, srs, r, sb) for r in _items(before)}
            for r in _items(before):
                _observe(con, srs, ids[r.id], sb, r)
        else:
            held = con.execute("SELECT kind FROM surveys WHERE survey = ?", (last[0],)).fetchone()[0]
            if held != change.kind:
                raise InputError(f"{p}: a register of {held}; expected results of {held} to add (these "
                                 f"hold {change.kind})")
            if last[2] != _sha(bfile):
                raise InputError(f"{p}: its last survey is {last[1]}; expected the before survey {bfile} "
                                 "to be it (surveys are added in order)")
            sb = int(last[0])
            ids = {int(r[1]): int(r[0]) for r in con.execute(
                "SELECT object, result_id FROM observations WHERE survey = ?", (sb,))}
        sa = _add_survey(con, after, afile, change)
        by_after = {r.id: r for r in _items(after)}
        for o in change.objects:
            if o.status == "new" and o.id_after is not None:
                obj = _new_object(con, srs, by_after[o.id_after], sa)
            elif o.id_before is not None:
                obj = ids[o.id_before]
            else:
                continue
            if o.status == "removed" or o.id_after is None:
                con.execute("UPDATE objects SET status = 'removed' WHERE object = ?", (obj,))
            else:
                r = by_after[o.id_after]
                _observe(con, srs, obj, sa, r)
                con.execute("UPDATE objects SET last_survey = ?, status = 'present', x = ?, y = ?, geom = ? "
                            "WHERE object = ?", (sa, r.x, r.y, point_blob(r.x, r.y, srs), obj))
            if o.status in ("changed", "unchanged", "removed"):
                _change_row(con, srs, obj, sb, sa, o)
        n = int(con.execute("SELECT count(*) FROM objects").fetchone()[0])
    return {"survey_before": sb, "survey_after": sa, "objects": n}


def _add_survey(con: sqlite3.Connection, result: ReefResult | PileResult, file: Path,
                change: ChangeResult | None) -> int:
    n = int(con.execute("SELECT coalesce(max(survey), 0) FROM surveys").fetchone()[0]) + 1
    inputs = result.parameters.get("input") or {}
    records = inputs.get("files") or [inputs]
    sources = [r.get("file") for r in records if isinstance(r, dict) and r.get("file")]
    ref = (result.parameters.get("vertical_reference") or {}).get("text") or "as the files give them"
    reg = change.registration if change is not None else None
    kind = "piles" if isinstance(result, PileResult) else "reefs"
    con.execute("INSERT INTO surveys (survey, result, result_sha256, sources, added, kind, objects, "
                "vertical_reference, dx, dy, dz) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                (n, str(file), _sha(file), json.dumps(sources),
                 dt.datetime.now(dt.UTC).isoformat(timespec="seconds"), kind,
                 len(_items(result)), ref, *(_num(getattr(reg, k, None)) for k in ("dx", "dy", "dz"))))
    return n


def _items(result: ReefResult | PileResult) -> tuple[Any, ...]:
    """A result's objects: its reefs or its piles."""
    return tuple(result.piles) if isinstance(result, PileResult) else tuple(result.reefs)


def _new_object(con: sqlite3.Connection, srs: int, r: Any, survey: int) -> int:
    obj = int(con.execute("SELECT coalesce(max(object), 0) FROM objects").fetchone()[0]) + 1
    con.execute("INSERT INTO objects (geom, object, design, first_survey, last_survey, status, x, y) "
                "VALUES (?, ?, ?, ?, ?, 'present', ?, ?)",
                (point_blob(r.x, r.y, srs), obj, _design(r), survey, survey, r.x, r.y))
    return obj


def _design(r: Any) -> str | None:
    """A reef's design, or 'pile' and its radius."""
    return getattr(r, "design", None) or (f"pile r {r.radius:.2f} m" if hasattr(r, "radius") else None)


def _observe(con: sqlite3.Connection, srs: int, obj: int, survey: int, r: Any) -> None:
    least = r.least or {}
    top = r.z_top if hasattr(r, "z_top") else (r.top_z if r.top_z is not None else r.z)
    tilt = getattr(r, "top_tilt_deg", getattr(r, "tilt_deg", None))
    overturned = getattr(r, "overturned", None)
    con.execute("INSERT INTO observations (geom, object, survey, result_id, x, y, z_top, height, "
                "least_depth, least_depth_tvu95, design, design_bearing_deg, top_tilt_deg, overturned) "
                "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                (point_blob(r.x, r.y, srs), obj, survey, r.id, r.x, r.y, _num(top),
                 _num(getattr(r, "height", None)),
                 _num(least.get("least_depth")), _num(least.get("least_depth_tvu95")), _design(r),
                 _num(getattr(r, "design_bearing_deg", None)), _num(tilt),
                 None if overturned is None else ("yes" if overturned else "no")))


def _change_row(con: sqlite3.Connection, srs: int, obj: int, sb: int, sa: int, o: Any) -> None:
    cols = [c for m, _, _ in MEASURES for c in (m, f"{m}_lod95")]
    ends = [(o.x_before, o.y_before)] + ([(o.x_after, o.y_after)] if o.status != "removed" else [])
    geom = line_blob(ends if len(ends) == 2 else ends * 2, srs)
    con.execute(f"INSERT INTO changes (geom, object, survey_before, survey_after, status, detected, "
                f"{', '.join(cols)}) VALUES ({', '.join('?' * (6 + len(cols)))})",
                (geom, obj, sb, sa, o.status, ";".join(o.detected) or None,
                 *(_num(o.values.get(c)) for c in cols)))


def _num(v: Any) -> float | None:
    return float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) else None


def last_two(path: str | Path) -> tuple[str, str]:
    """The result files of the register's last two surveys (before, after)."""
    rows = _read(path, "SELECT result FROM surveys ORDER BY survey DESC LIMIT 2")
    if len(rows) < 2:
        raise InputError(f"{path}: holds {len(rows)} survey(s); expected two or more to compare")
    return str(rows[1][0]), str(rows[0][0])


def history(path: str | Path, obj: int) -> dict[str, Any]:
    """One unit's life: its record, each survey's observation and each change."""
    rows = _read(path, "SELECT object, design, first_survey, last_survey, status, x, y FROM objects "
                       "WHERE object = ?", (obj,))
    if not rows:
        n = _read(path, "SELECT max(object) FROM objects")[0][0]
        raise InputError(f"{path}: no unit {obj}; expected one of 1..{n or 0}")
    keys = ("object", "design", "first_survey", "last_survey", "status", "x", "y")
    seen = _read(path, "SELECT survey, result_id, x, y, z_top, height, least_depth, top_tilt_deg, overturned "
                       "FROM observations WHERE object = ? ORDER BY survey", (obj,))
    changes = _read(path, "SELECT survey_before, survey_after, status, detected, displacement, "
                          "displacement_lod95, settlement, settlement_lod95, scour_depth, scour_depth_lod95 "
                          "FROM changes WHERE object = ? ORDER BY survey_after", (obj,))
    kind = _read(path, "SELECT kind FROM surveys ORDER BY survey LIMIT 1")
    return {**dict(zip(keys, rows[0], strict=True)), "kind": kind[0][0] if kind else "reefs",
            "observations": [dict(zip(("survey", "result_id", "x", "y", "z_top", "height", "least_depth",
                                       "top_tilt_deg", "overturned"), r, strict=True)) for r in seen],
            "changes": [dict(zip(("survey_before", "survey_after", "status", "detected", "displacement",
                                  "displacement_lod95", "settlement", "settlement_lod95", "scour_depth",
                                  "scour_depth_lod95"), r, strict=True)) for r in changes]}


def _read(path: str | Path, sql: str, args: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    p = Path(path)
    if not p.is_file():
        raise InputError(f"{p}: no such file")
    con = sqlite3.connect(f"file:{p}?mode=ro", uri=True)
    try:
        _check(con, p)
        return list(con.execute(sql, args))
    finally:
        con.close()
