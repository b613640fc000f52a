"""Readers of the sonar makers' own formats: GSF, Kongsberg KMALL and Kongsberg .all.

Each reader returns :class:`Soundings`: per-sounding geographic position, elevation and
what the file knows of each sounding (ping, beam, beam angle, backscatter, time, the
file's own validity flags, uncertainty where given). :func:`to_cloud` projects them to a
projected CRS (the UTM zone of the data by default) as a :class:`~mbinspect.io.PointCloud`.

Heights are elevations (up, metres) relative to the level the format gives: the water
level at the time of the ping for KMALL and .all (no tide applied), and for GSF the level
its depths were reduced to (the file's own tide and draft correctors already applied).
"""

from .common import Soundings, to_cloud, utm_crs
from .read import READERS, read_sonar

__all__ = ["Soundings", "to_cloud", "utm_crs", "read_sonar", "READERS"]
