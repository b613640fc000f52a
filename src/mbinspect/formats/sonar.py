"""The sonar makers' formats (GSF, Kongsberg KMALL and .all, XTF of R2Sonic bathymetry) as rows of
the format table: read by :mod:`mbinspect.sonar` and projected (the data's UTM zone, or ``crs``)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from ..cloud import PointCloud
from ..sonar import Soundings, to_cloud
from ..sonar.gsf import read_gsf
from ..sonar.kmall import read_kmall
from ..sonar.kongsberg_all import read_all
from ..sonar.xtf import read_xtf
from .base import Format, ReadRequest

__all__ = ["GSF", "KMALL", "ALL", "XTF"]

_FIELDS = "ping, beam, beam_angle, intensity, time, valid, sigma_h, sigma_v where the file has them"


def _reader(read: Callable[[str], Soundings]) -> Callable[[Path, ReadRequest], PointCloud]:
    def _read(path: Path, request: ReadRequest) -> PointCloud:
        return to_cloud(read(str(path)), crs=request.crs, keep_rejected=request.keep_rejected)

    return _read


GSF = Format("gsf", (".gsf", ".mb121"), _reader(read_gsf), None, 12.0, options=("keep_rejected",),
             sonar=True, fields=_FIELDS)
KMALL = Format("kmall", (".kmall", ".mb261"), _reader(read_kmall), None, 20.0, options=("keep_rejected",),
               sonar=True, fields=_FIELDS)
#: MB-System names Kongsberg's .all files .mb56-.mb59 by their sonar generation and KMALL .mb261.
ALL = Format("all", (".all", ".mb56", ".mb57", ".mb58", ".mb59"), _reader(read_all), None, 16.0,
             options=("keep_rejected",), sonar=True, fields=_FIELDS)
#: XTF as QINSy records an R2Sonic's own bathymetry packets (type 65).
XTF = Format("xtf", (".xtf",), _reader(read_xtf), None, 9.2, options=("keep_rejected",), sonar=True,
             fields=_FIELDS)
