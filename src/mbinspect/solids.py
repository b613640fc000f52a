"""Boxes turned any way in space: a ray's first hit on one, their corners, and the upper
surface of a union of them seen from above.

A reef unit is a union of boxes; upright, each box stands on its base with vertical sides,
but a unit dropped on its side or resting on a rock has its boxes turned about a horizontal
axis. The simulator casts its beams against them and the reef chain renders a design in
each orientation from them, so both read the same geometry.

A box is its base centre (the middle of its bottom face), its three unit axes as rows
(length, width, height directions, in the world frame) and its length, width and height.

Examples
--------
>>> import numpy as np
>>> axes = np.eye(3)
>>> t, n = ray_box(np.zeros(3), axes, (2.0, 2.0, 1.0), np.array([[0.0, 0.0, 5.0]]),
...                np.array([[0.0, 0.0, -1.0]]))
>>> t.tolist(), n.tolist()
([4.0], [[0.0, 0.0, 1.0]])
>>> turn((1.0, 0.0, 0.0), 90.0).round(6).tolist()[2]
[0.0, 1.0, 0.0]
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

__all__ = ["turn", "ray_box", "box_corners", "upper_surface"]


def turn(axis: Sequence[float], angle_deg: float) -> np.ndarray:
    """The rotation matrix (3, 3) that turns vectors by ``angle_deg`` about ``axis``
    (right-handed: counter-clockwise looking down the axis)."""
    a = np.asarray(axis, np.float64)
    a = a / np.linalg.norm(a)
    t = math.radians(angle_deg)
    k = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    return np.eye(3) + math.sin(t) * k + (1.0 - math.cos(t)) * (k @ k)


def ray_box(base: np.ndarray, axes: np.ndarray, size: Sequence[float], o: np.ndarray,
            d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where rays first meet a box (slab test in the box's own frame).

    Parameters
    ----------
    base : ndarray, shape (3,)
        The centre of the box's bottom face.
    axes : ndarray, shape (3, 3)
        Unit length, width and height directions as rows (world frame).
    size : (length, width, height)
        Metres.
    o, d : ndarray, shape (N, 3)
        Ray origins and unit directions.

    Returns
    -------
    t : ndarray, shape (N,)
        Ray parameter of the first hit (inf: a miss, or the origin inside the box).
    normal : ndarray, shape (N, 3)
        Outward surface normal there (world frame).
    """
    ol = (o - np.asarray(base, np.float64)) @ axes.T
    dl = d @ axes.T
    lo = np.array([-size[0] / 2, -size[1] / 2, 0.0])
    hi = np.array([size[0] / 2, size[1] / 2, size[2]])
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = (lo - ol) / dl
        t2 = (hi - ol) / dl
    tmin = np.fmin(t1, t2)
    tmax = np.fmax(t1, t2)
    tmin = np.where(np.isnan(tmin), -np.inf, tmin)
    tmax = np.where(np.isnan(tmax), np.inf, tmax)
    rows = np.arange(len(ol))
    near_axis = np.argmax(tmin, axis=1)
    tnear = tmin[rows, near_axis]
    tfar = tmax.min(axis=1)
    ok = (tnear <= tfar) & (tnear > 0)
    nl = np.zeros_like(ol)
    nl[rows, near_axis] = -np.sign(dl[rows, near_axis])
    return np.where(ok, tnear, np.inf), nl @ axes


def box_corners(base: np.ndarray, axes: np.ndarray, size: Sequence[float]) -> np.ndarray:
    """The eight corners of a box, shape (8, 3)."""
    sx = np.array([-0.5, 0.5])[:, None, None] * size[0] * axes[0]
    sy = np.array([-0.5, 0.5])[None, :, None] * size[1] * axes[1]
    out = np.asarray(base, np.float64) + (sx + sy)[..., None, :] + \
        np.array([0.0, size[2]])[None, None, :, None] * axes[2]
    return out.reshape(8, 3)


def upper_surface(boxes: Sequence[tuple[np.ndarray, np.ndarray, Sequence[float]]],
                  xy: np.ndarray) -> np.ndarray:
    """The highest point of a union of boxes straight above each plan point (N, 2):
    heights (N,), -inf where no box stands.

    Parameters
    ----------
    boxes : sequence of (base, axes, size)
        As :func:`ray_box` takes them.
    xy : ndarray, shape (N, 2)
    """
    xy = np.asarray(xy, np.float64)
    top = max(float(box_corners(*b)[:, 2].max()) for b in boxes) + 1.0 if boxes else 0.0
    o = np.column_stack([xy, np.full(len(xy), top)])
    d = np.tile([0.0, 0.0, -1.0], (len(xy), 1))
    t = np.full(len(xy), np.inf)
    for b in boxes:
        t = np.minimum(t, ray_box(*b, o, d)[0])
    return top - t
