"""mbinspect: engineering answers about underwater structures from multibeam point clouds."""

from __future__ import annotations

from .errors import MBInspectError
from .io import PointCloud, read, write

__version__ = "0.1.0"
__all__ = ["MBInspectError", "PointCloud", "read", "write", "__version__"]
