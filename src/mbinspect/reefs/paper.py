"""The paper's plain method: Euclidean clusters of the points off one plane as reefs."""

from __future__ import annotations

import numpy as np

from ..geometry import convex_hull, min_area_rectangle, polygon_area
from ..segment import components
from .ground import Seabed
from .results import OtherObject, Reef

__all__ = ["paper_clusters"]


def paper_clusters(points: np.ndarray, is_reef: np.ndarray, seabed: Seabed, *, eps: float,
                    min_area: float) -> tuple[list[Reef], list[OtherObject]]:
    """The paper's individual reefs: Euclidean clusters of the off-plane points.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
    is_reef : ndarray of bool, shape (N,)
        The points off the plane.
    seabed : Seabed
    eps : float
        Clustering distance (m).
    min_area : float
        Smaller clusters (hull area, m²) are other objects.

    Examples
    --------
    >>> from mbinspect.simulate import simulate
    >>> sim = simulate("reef-field", seed=1, groups="cross1", per_group=4, ping_spacing=0.4,
    ...                close_pairs=0, boulders=0, debris=0)
    >>> from mbinspect.reefs import fit_seabed
    >>> plane, _ = fit_seabed(sim.cloud.xyz, mode="plane")
    >>> h = plane.height_above(sim.cloud.xyz)
    >>> reefs, others = paper_clusters(sim.cloud.xyz, h > 0.5, plane, eps=0.5, min_area=1.0)
    >>> len(reefs)
    4

    Returns
    -------
    reefs : list of Reef
    others : list of OtherObject
    """
    idx = np.flatnonzero(is_reef)
    lab = components(points[idx], eps=eps, min_points=5)
    reefs, others = [], []
    for k in range(lab.max() + 1 if len(lab) else 0):
        p = points[idx[lab == k]]
        hull = convex_hull(p[:, :2])
        area = abs(polygon_area(hull)) if len(hull) >= 3 else 0.0
        x, y = p[:, :2].mean(axis=0)
        z_sea = float(seabed.elevation(np.array([x]), np.array([y]))[0])
        z_top = float(p[:, 2].max())
        rect = min_area_rectangle(p[:, :2])
        if area < min_area:
            others.append(OtherObject(float(x), float(y), z_top - z_sea, area, z_top, len(p),
                                      "smaller than `min_area`"))
            continue
        h = z_top - z_sea
        reefs.append(Reef(0, float(x), float(y), z_sea, z_top, h, area, rect.length, rect.width,
                          rect.bearing_deg, area * h, rect.length * rect.width * h, len(p),
                          outline=tuple(map(tuple, np.round(hull, 3).tolist()))))
    return reefs, others
