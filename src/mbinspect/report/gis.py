"""GIS layers: GeoJSON in WGS 84 (RFC 7946) and in the survey's own CRS, and the CRS named."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..io import crs_name
from ..outputs import atomic_path

__all__ = ["crs_of", "crs_label", "crs_name", "lonlat_transform", "write_geojson", "write_gis"]


def crs_of(result: Any) -> str | None:
    """The CRS (WKT) of a result's coordinates, as its input gave it, or None."""
    crs: str | None = result.parameters.get("input", {}).get("crs")
    return crs


def crs_label(result: Any) -> str:
    """A line naming a result's CRS, or saying there is none."""
    name = crs_name(crs_of(result))
    return name or "the input's own coordinates (no CRS given: give --crs to place them on a map)"


def heights_label(result: Any) -> str:
    """A line saying what a result's heights are (its ``parameters["vertical_reference"]``,
    as ``--tide`` and ``--datum-offset`` stated it), or that they are as the files gave them."""
    from ..datum import as_given

    ref = result.parameters.get("vertical_reference") if isinstance(result.parameters, dict) else None
    return str(ref["text"]) if ref else as_given().describe()


def lonlat_transform(crs: str | None) -> Any:
    """``f(x, y) -> (lon, lat)`` from ``crs`` to WGS 84, or None without a CRS.

    Parameters
    ----------
    crs : str or None
        WKT or any CRS pyproj accepts.

    Returns
    -------
    callable or None
    """
    if crs is None:
        return None
    from pyproj import Transformer

    return Transformer.from_crs(crs, "EPSG:4326", always_xy=True).transform


def write_geojson(features: list[dict[str, Any]], path: Path, *, lonlat: bool,
                  crs_name: str | None = None) -> None:
    """A GeoJSON FeatureCollection, atomically.

    With ``lonlat`` the coordinates are WGS 84 longitude and latitude, as RFC 7946 says; a
    GIS places them without being told. Without it (no CRS known) they are the input's own
    coordinates, and the file says so in a ``crs_note`` member.

    Parameters
    ----------
    features : list of dict
    path : Path
    lonlat : bool
    crs_name : str, optional
        A named CRS (``urn:ogc:def:crs:EPSG::32631``) for coordinates that are not WGS 84:
        written as the GeoJSON 2008 ``crs`` member, which GDAL and QGIS honour.
    """
    import json

    from ..outputs import to_jsonable

    doc: dict[str, Any] = {"type": "FeatureCollection", "features": features}
    if crs_name is not None:
        doc["crs"] = {"type": "name", "properties": {"name": crs_name}}
    elif not lonlat:
        doc["crs_note"] = "coordinates in the input's own (unknown) CRS, not WGS 84"
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(to_jsonable(doc)) + "\n", encoding="utf-8")


def write_gis(features: list[dict[str, Any]], crs: str | None, out: Path, stem: str) -> list[str]:
    """The features as GeoJSON a GIS places right: ``STEM.geojson`` in WGS 84 longitude and
    latitude (RFC 7946) and, when the CRS has an EPSG code, ``STEM_projected.geojson`` in the
    survey's own CRS, named in a ``crs`` member (which GDAL and QGIS read).

    Parameters
    ----------
    features : list of dict
        Point, LineString or Polygon features in the survey's projected coordinates (m).
    crs : str or None
        Their CRS (WKT); None: one file in those coordinates, saying so.
    out : Path
    stem : str

    Returns
    -------
    list of str
        The files written.
    """
    to_lonlat = lonlat_transform(crs)
    if to_lonlat is None:
        write_geojson(features, out / f"{stem}.geojson", lonlat=False)
        return [f"{stem}.geojson"]

    def moved(geom: dict[str, Any] | None) -> dict[str, Any] | None:
        if geom is None:
            return None
        if geom["type"] == "Point":
            lon, lat = to_lonlat(np.array([geom["coordinates"][0]]), np.array([geom["coordinates"][1]]))
            return {"type": "Point", "coordinates": [float(lon[0]), float(lat[0])]}
        if geom["type"] == "LineString":  # a list of positions, not of rings
            lon, lat = to_lonlat(*np.asarray(geom["coordinates"], np.float64).reshape(-1, 2).T)
            return {"type": "LineString",
                    "coordinates": [[float(a), float(b)] for a, b in zip(lon, lat, strict=True)]}
        rings = []
        for ring in geom["coordinates"]:
            lon, lat = to_lonlat(*np.asarray(ring, np.float64).reshape(-1, 2).T)
            rings.append([[float(a), float(b)] for a, b in zip(lon, lat, strict=True)])
        return {"type": geom["type"], "coordinates": rings}

    write_geojson([{**f, "geometry": moved(f["geometry"])} for f in features], out / f"{stem}.geojson",
                  lonlat=True)
    from pyproj import CRS

    epsg = CRS.from_user_input(crs).to_epsg()
    if epsg is None:
        return [f"{stem}.geojson"]
    write_geojson(features, out / f"{stem}_projected.geojson", lonlat=True,
                  crs_name=f"urn:ogc:def:crs:EPSG::{epsg}")
    return [f"{stem}.geojson", f"{stem}_projected.geojson"]
