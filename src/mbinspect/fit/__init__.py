"""Geometric models and one robust estimation loop (RANSAC / MSAC) that serves them all.

Each model is a small immutable class with a least-squares fit from points and
``residuals(points)`` as true orthogonal distances (signed where a side is defined); each
meets the :class:`GeometricModel` protocol. A degenerate sample gives ``None`` ("no
model"), never an exception. Two models are equal when their parameters are equal
(arrays compared element by element), so models can be compared and hashed.

Examples
--------
>>> import numpy as np
>>> from mbinspect.fit import Plane, msac
>>> rng = np.random.default_rng(0)
>>> xy = rng.uniform(-5, 5, (200, 2))
>>> pts = np.column_stack([xy, 0.1 * xy[:, 0] - 20 + rng.normal(0, 0.01, 200)])
>>> pts[:20, 2] += 3.0                      # outliers
>>> res = msac(pts, Plane.from_sample, lambda m, p: m.residuals(p), 3, 0.05, seed=1)
>>> bool(res.inliers[20:].all()), bool(res.inliers[:20].any())
(True, False)
"""

from __future__ import annotations

from .cylinder import cylinder_from_normals, cylinder_msac, fit_cylinder
from .models import Circle, Cylinder, GeometricModel, Plane
from .robust import RobustResult, clustered_cov, msac, ransac_trials

__all__ = [
    "GeometricModel",
    "Plane",
    "Cylinder",
    "Circle",
    "RobustResult",
    "msac",
    "ransac_trials",
    "clustered_cov",
    "fit_cylinder",
    "cylinder_from_normals",
    "cylinder_msac",
]
