"""What a format row holds: how a file of that format is read, written and sized.

Each reader module defines one :class:`Format`; :mod:`mbinspect.formats` gathers them into
``FORMATS``, from which every other list (extensions, aliases, command-line choices, the
survey's memory estimate) is derived.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..cloud import PointCloud

__all__ = ["Format", "ReadRequest"]


@dataclass(frozen=True)
class ReadRequest:
    """The reading options :func:`mbinspect.io.read` passes to a format's reader (each
    reader takes those it knows; :attr:`Format.options` names them)."""

    columns: Any = None
    delimiter: str | None = None
    decimal: str | None = None
    depth_positive: bool = False
    z_up: bool = False
    crs: str | None = None
    keep_rejected: bool = False
    progress: Callable[[float], None] | None = None


@dataclass(frozen=True)
class Format:
    """One row of the format table.

    Attributes
    ----------
    name : str
        What ``format=`` takes (``xyz``, ``las``, ...).
    extensions : tuple of str
        Lower-case suffixes that select it, with the dot.
    read : callable
        ``read(path, request) -> PointCloud``.
    write : callable or None
        ``write(cloud, path, precision)``; None for a format read only.
    bytes_per_sounding : float
        Bytes a sounding takes in the file (the survey's estimate of its soundings).
    aliases : tuple of str
        Other names ``format=`` takes for it.
    options : tuple of str
        Reading options besides ``crs`` that apply (``columns``, ``delimiter``, ...).
    sonar : bool
        A sonar maker's format: geographic soundings projected on reading, heights as the
        file states them (``depth_positive`` does not apply).
    count : callable, optional
        ``count(path) -> int``: the exact number of soundings from the header.
    chunks : callable, optional
        ``chunks(path, n, keep_rejected=False) -> iterator of PointCloud``: the file read
        ``n`` soundings at a time, what the file rejects left out as a whole read does.
    fields : str
        The per-point fields kept, for the documentation.
    writes : tuple of str
        The extensions its writer makes distinct files of (``.las`` and compressed
        ``.laz``); the first extension when not given.
    """

    name: str
    extensions: tuple[str, ...]
    read: Callable[[Path, ReadRequest], PointCloud]
    write: Callable[[PointCloud, Path, int], None] | None
    bytes_per_sounding: float
    aliases: tuple[str, ...] = ()
    options: tuple[str, ...] = ()
    sonar: bool = False
    count: Callable[[Path], int] | None = None
    chunks: Callable[..., Iterator[PointCloud]] | None = None
    fields: str = ""
    writes: tuple[str, ...] = ()

    @property
    def written_extensions(self) -> tuple[str, ...]:
        """What :attr:`writes` names, or the first extension; none for a format read only."""
        if self.write is None:
            return ()
        return self.writes or self.extensions[:1]
