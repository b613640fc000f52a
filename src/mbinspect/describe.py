"""What ``mbinspect info`` says of a cloud: counts, extent, fields, density, spacing and
what a sonar file says."""

from __future__ import annotations

import datetime as dt
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .checks import positive
from .cloud import PointCloud, crs_name
from .formats import SONAR_FORMATS
from .grid import corner_cell_keys, patched_spacing
from .outputs import dataclasses_asdict

__all__ = ["CloudSummary", "describe"]



@dataclass(frozen=True)
class CloudSummary:
    """What ``mbinspect info`` prints: counts, extent, fields, density and what the file says.

    Attributes
    ----------
    n_points : int
    bounds_min, bounds_max : tuple of float
        Corners (x, y, z) in metres.
    fields : tuple of str
    area : float
        Covered area (m^2): occupied cells of a ``cell`` m grid.
    density : float
        Mean points per covered m^2.
    spacing : float
        Median plan distance to the nearest other point (m), the neighbours searched among
        all the points (a sample of up to 200 000 points is measured).
    cell : float
        The grid cell of ``area`` (m): given, or chosen from the spacing.
    crs, crs_name : str or None
        The CRS (WKT) and its name.
    sonar : dict
        For sonar files: format, sonar, pings, beam-angle range (deg), time span (UTC).
    """

    source: str | None
    n_points: int
    bounds_min: tuple[float, float, float]
    bounds_max: tuple[float, float, float]
    fields: tuple[str, ...]
    area: float
    density: float
    spacing: float
    cell: float
    crs: str | None
    z_convention: str
    crs_name: str | None = None
    sonar: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """The summary as JSON-ready values (``mbinspect info --json``)."""
        d = dataclasses_asdict(self)
        d["z_range"] = [self.bounds_min[2], self.bounds_max[2]]
        return d


def _nice_cell(spacing: float) -> float:
    """A round grid cell (m) about three sounding spacings wide, at least 0.1 m."""
    if not math.isfinite(spacing) or spacing <= 0:
        return 1.0
    target = max(0.1, 3.0 * spacing)
    steps = np.array([1.0, 2.0, 5.0, 10.0])
    base = 10.0 ** math.floor(math.log10(target))
    return float(base * steps[np.searchsorted(steps, target / base - 1e-9)])


def _sonar_summary(cloud: PointCloud) -> dict[str, Any]:
    meta = dict(cloud.meta)
    if meta.get("format") not in SONAR_FORMATS:
        return {}
    keys = ("format", "sonar", "version", "pings", "lines", "level")
    out: dict[str, Any] = {k: meta.get(k) for k in keys if k in meta}
    if "beam_angle" in cloud.fields and len(cloud):
        a = cloud.fields["beam_angle"]
        out["beam_angle_range_deg"] = [float(np.nanmin(a)), float(np.nanmax(a))]
    if "time" in cloud.fields and len(cloud):

        t = cloud.fields["time"]
        out["time_span"] = [dt.datetime.fromtimestamp(float(v), dt.UTC).isoformat(timespec="seconds")
                            for v in (np.nanmin(t), np.nanmax(t))]
    return out


def _covered_cells(xyz: np.ndarray, lo: np.ndarray, extent: np.ndarray, cell: float) -> float:
    """How many cells of ``cell`` metres hold a sounding."""
    keys, ny = corner_cell_keys(xyz, lo, extent, cell)
    cells = (int(extent[0] / cell) + 2) * ny
    if cells <= 50_000_000:  # a flag per cell: no sort of the soundings
        seen = np.zeros(cells, bool)
        seen[keys] = True
        return float(np.count_nonzero(seen))
    return float(len(np.unique(keys)))


def describe(cloud: PointCloud, *, cell: float | None = None, seed: int = 0) -> CloudSummary:
    """Summarise a cloud like ``pdal info`` or ``lasinfo`` do.

    Parameters
    ----------
    cloud : PointCloud
    cell : float, optional
        Grid cell (m) used to measure the covered area; default about three sounding
        spacings, rounded (so sparse deep data and dense shallow data both read right).
    seed : int
        Seed of the sample of points whose nearest neighbour is measured.

    Returns
    -------
    CloudSummary

    Examples
    --------
    >>> g = np.arange(0.0, 10.0, 0.1)
    >>> c = PointCloud(np.column_stack([np.repeat(g, 100), np.tile(g, 100), np.full(10_000, -20.0)]))
    >>> s = describe(c)
    >>> round(s.spacing, 3), s.cell, round(s.area), round(s.density)
    (0.1, 0.5, 100, 100)
    """

    if cell is not None:
        positive("cell", cell)
    lo, hi = cloud.bounds()
    # the neighbours are searched among all points: a subsample's own neighbours lie
    # several spacings apart and would overstate the spacing
    spacing = patched_spacing(cloud.xyz, seed=seed)
    used = cell if cell is not None else _nice_cell(spacing)
    area = _covered_cells(cloud.xyz, lo, hi - lo, used) * used * used
    return CloudSummary(
        source=cloud.source, n_points=len(cloud),
        bounds_min=tuple(float(v) for v in lo), bounds_max=tuple(float(v) for v in hi),  # type: ignore[arg-type]
        fields=tuple(cloud.fields), area=area, density=len(cloud) / area, spacing=spacing,
        cell=used, crs=cloud.crs, z_convention=cloud.z_convention,
        crs_name=crs_name(cloud.crs, epsg=False) if cloud.crs else None,
        sonar=_sonar_summary(cloud),
    )
