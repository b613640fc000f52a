"""mbinspect: engineering answers about underwater structures from multibeam point clouds.

``PointCloud``, ``read`` and ``write`` come from :mod:`mbinspect.io`, imported on first
use, so that the command line can set up its signal handling before numpy starts threads.
"""

from __future__ import annotations

from typing import Any

from .errors import MBInspectError
from .version import __version__

__all__ = ["MBInspectError", "PointCloud", "read", "write", "__version__"]


def __getattr__(name: str) -> Any:
    if name in ("PointCloud", "read", "write"):
        from . import io

        return getattr(io, name)
    raise AttributeError(f"module 'mbinspect' has no attribute {name!r}")
