"""Which reader reads which sonar format."""

from __future__ import annotations

import os

from .common import Soundings
from .gsf import read_gsf
from .kmall import read_kmall
from .kongsberg_all import read_all
from .xtf import read_xtf

__all__ = ["READERS", "read_sonar"]

#: Sonar format name -> reader.
READERS = {"gsf": read_gsf, "kmall": read_kmall, "all": read_all, "xtf": read_xtf}


def read_sonar(path: str | os.PathLike[str], format: str) -> Soundings:
    """The soundings of a sonar file, by the reader of ``format``.

    Parameters
    ----------
    path : path-like
    format : {"gsf", "kmall", "all", "xtf"}

    Returns
    -------
    Soundings

    Examples
    --------
    >>> sorted(READERS)
    ['all', 'gsf', 'kmall', 'xtf']
    """
    return READERS[format](str(path))
