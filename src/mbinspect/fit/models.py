"""The geometric models: small immutable classes with a least-squares fit and true orthogonal
residuals, meeting :class:`GeometricModel`."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np
from scipy.optimize import least_squares

__all__ = ["GeometricModel", "Plane", "Circle", "Cylinder"]


@runtime_checkable
class GeometricModel(Protocol):
    """What every geometric model offers: orthogonal residuals and a JSON summary."""

    def residuals(self, points: np.ndarray) -> np.ndarray:
        """Orthogonal distance (m) of each point ``(N, 3)`` to the model, shape (N,)."""
        ...

    def to_dict(self) -> dict[str, Any]:
        """The model's parameters, JSON-ready."""
        ...


class _ArrayFields:
    """Equality and hashing by value for frozen dataclasses with ndarray fields."""

    def _key(self) -> tuple[Any, ...]:
        return tuple(np.asarray(v).tobytes() if isinstance(v, np.ndarray) else v
                     for v in (getattr(self, f) for f in self.__dataclass_fields__))  # type: ignore[attr-defined]

    def __eq__(self, other: object) -> bool:
        if type(other) is not type(self):
            return NotImplemented
        return self._key() == other._key()

    def __hash__(self) -> int:
        return hash((type(self).__name__, self._key()))


@dataclass(frozen=True, eq=False)
class Plane(_ArrayFields):
    """A plane through ``point`` with unit ``normal`` (pointing up, n_z >= 0)."""

    point: np.ndarray
    normal: np.ndarray

    @classmethod
    def fit(cls, points: np.ndarray, weights: np.ndarray | None = None) -> Plane | None:
        """Orthogonal least squares (total least squares) through ``points`` (N >= 3)."""
        pts = np.asarray(points, dtype=np.float64)
        if len(pts) < 3:
            return None
        w = np.ones(len(pts)) if weights is None else np.asarray(weights, np.float64)
        c = (pts * w[:, None]).sum(axis=0) / w.sum()
        _, s, vt = np.linalg.svd((pts - c) * np.sqrt(w)[:, None], full_matrices=False)
        if s[1] < 1e-9 * max(s[0], 1e-300):
            return None
        n = vt[2]
        return cls(c, n if n[2] >= 0 else -n)

    @classmethod
    def from_sample(cls, sample: np.ndarray) -> Plane | None:
        """The plane through three points, or None when they are (nearly) collinear."""
        p = np.asarray(sample, np.float64)[:, :3]
        # in plain floats: MSAC draws thousands of samples, each three points
        (ax, ay, az), (bx, by, bz), (cx, cy, cz) = p[:3].tolist()
        ux, uy, uz, vx, vy, vz = bx - ax, by - ay, bz - az, cx - ax, cy - ay, cz - az
        nx, ny, nz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
        norm = math.sqrt(nx * nx + ny * ny + nz * nz)
        scale = max(math.sqrt(ux * ux + uy * uy + uz * uz) * math.sqrt(vx * vx + vy * vy + vz * vz), 1e-300)
        if norm < 1e-6 * scale:
            return None
        sign = 1.0 if nz >= 0 else -1.0
        return cls(p[0].copy(), np.array([nx, ny, nz]) * (sign / norm))

    def residuals(self, points: np.ndarray) -> np.ndarray:
        """Signed orthogonal distance of each point (positive above)."""
        return (np.asarray(points, np.float64)[:, :3] - self.point) @ self.normal

    def z_at(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Elevation of the plane at ``x, y`` (the plane must not be vertical)."""
        n, c = self.normal, self.point
        return c[2] - (n[0] * (np.asarray(x) - c[0]) + n[1] * (np.asarray(y) - c[1])) / n[2]

    @property
    def slope_deg(self) -> float:
        """Angle of the plane from horizontal (deg)."""
        return math.degrees(math.acos(min(1.0, abs(float(self.normal[2])))))

    def to_dict(self) -> dict[str, Any]:
        """A point on the plane, its unit normal and its slope (deg)."""
        return {"point": self.point.tolist(), "normal": self.normal.tolist(),
                "slope_deg": self.slope_deg}


@dataclass(frozen=True, eq=False)
class Circle(_ArrayFields):
    """A circle in the plane: centre (2,) and radius."""

    centre: np.ndarray
    radius: float

    @classmethod
    def fit(cls, points: np.ndarray, *, radius: float | None = None) -> Circle | None:
        """Geometric least squares on ``|p - c| - r`` (algebraic start); fixed r if given."""
        p = np.asarray(points, np.float64)[:, :2]
        if len(p) < (2 if radius is not None else 3):
            return None
        A = np.column_stack([2 * p, np.ones(len(p))])
        b = (p**2).sum(axis=1)
        sol, *_ = np.linalg.lstsq(A, b, rcond=None)
        c0 = sol[:2]
        r0 = math.sqrt(max(float(sol[2] + c0 @ c0), 1e-12)) if radius is None else float(radius)
        if radius is None:
            res = least_squares(lambda q: np.hypot(*(p - q[:2]).T) - q[2], np.r_[c0, r0])
            return cls(res.x[:2], float(res.x[2]))
        res = least_squares(lambda q: np.hypot(*(p - q).T) - radius, c0)
        return cls(res.x, float(radius))

    def residuals(self, points: np.ndarray) -> np.ndarray:
        """Signed distance (m) of each point's plan position to the circle (positive outside)."""
        p = np.asarray(points, np.float64)[:, :2]
        return np.hypot(*(p - self.centre).T) - self.radius

    def to_dict(self) -> dict[str, Any]:
        """Centre (x, y) and radius (m)."""
        return {"centre": self.centre.tolist(), "radius": float(self.radius)}


@dataclass(frozen=True, eq=False)
class Cylinder(_ArrayFields):
    """An infinite cylinder: a point on its axis, the unit axis (pointing up), the radius."""

    point: np.ndarray
    axis: np.ndarray
    radius: float

    def residuals(self, points: np.ndarray) -> np.ndarray:
        """Signed orthogonal distance to the surface (positive outside)."""
        q = np.asarray(points, np.float64)[:, :3] - self.point
        d = q - (q @ self.axis)[:, None] * self.axis
        return np.sqrt(np.einsum("ij,ij->i", d, d)) - self.radius

    def angles(self, points: np.ndarray) -> np.ndarray:
        """Angle of each point around the axis, radians in [0, 2 pi), from grid east."""
        q = np.asarray(points, np.float64)[:, :3] - self.point
        q = q - np.outer(q @ self.axis, self.axis)
        return np.mod(np.arctan2(q[:, 1], q[:, 0]), 2 * np.pi)

    def intersect(self, plane: Plane) -> np.ndarray | None:
        """Where the axis meets ``plane`` (the pile paper's eq. 7), or None if parallel."""
        denom = float(self.axis @ plane.normal)
        if abs(denom) < 1e-9:
            return None
        t = float((plane.point - self.point) @ plane.normal) / denom
        return self.point + t * self.axis

    @property
    def tilt_deg(self) -> float:
        """Angle of the axis from vertical (deg)."""
        return math.degrees(math.acos(min(1.0, abs(float(self.axis[2])))))

    def to_dict(self) -> dict[str, Any]:
        """A point on the axis, the unit axis, the radius (m), the tilt and its bearing (deg)."""
        return {"point": self.point.tolist(), "axis": self.axis.tolist(), "radius": float(self.radius),
                "tilt_deg": self.tilt_deg, "tilt_bearing_deg": self.tilt_bearing_deg}

    @property
    def tilt_bearing_deg(self) -> float:
        """Bearing toward which the axis leans (deg clockwise from grid north)."""
        a = self.axis if self.axis[2] >= 0 else -self.axis
        return math.degrees(math.atan2(float(a[0]), float(a[1]))) % 360.0
