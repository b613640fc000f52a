"""What a simulation knows exactly: piles, spacings, reefs (their footprint and height)
and rocks, as ``truth.json`` holds them."""

from __future__ import annotations

import dataclasses
import itertools
import math
from typing import Any

import numpy as np

from ..geometry import (
    bearing_to_vector,
    convex_hull,
    min_area_rectangle,
    polygon_area,
)
from ..scour import grown
from ..solids import upper_surface
from .scene import LABELS, Reef, Scene, Seabed, reef_gap
from .sonar import Sonar


def reef_truth(reef: Reef, seabed: Seabed, origin: tuple[float, float], cell: float = 0.02
               ) -> dict[str, Any]:
    """A reef's truth record as ``truth.json`` holds it: centre, seabed and top elevations,
    exposed height, footprint area, rectangle, volume, outline and boxes.

    Measured on a ``cell`` m raster of the boxes' union; the height is the top above the
    seabed at the footprint's centre, so a sunk reef has its exposed height. Local
    coordinates, ``origin`` added on output.
    """
    corners = np.concatenate([bx.corners2d() for bx in reef.boxes])
    lo, hi = corners.min(axis=0), corners.max(axis=0)
    gx = np.arange(lo[0] + cell / 2, hi[0], cell)
    gy = np.arange(lo[1] + cell / 2, hi[1], cell)
    X, Y = np.meshgrid(gx, gy)
    pts = np.column_stack([X.ravel(), Y.ravel()])
    top = np.full(len(pts), -np.inf)
    if any(bx.axes for bx in reef.boxes):  # turned in space: the upper surface seen from above
        top = upper_surface([bx.solid() for bx in reef.boxes], pts)
    for bx in reef.boxes:
        if bx.axes:
            continue
        u = bearing_to_vector(bx.bearing_deg)
        rel = pts - np.array([bx.cx, bx.cy])
        inside = (np.abs(rel @ u) <= bx.length / 2) & (np.abs(rel @ np.array([u[1], -u[0]]))
                                                       <= bx.width / 2)
        top = np.where(inside, np.maximum(top, bx.z0 + bx.height), top)
    covered = np.isfinite(top)
    fp = pts[covered]
    sea = seabed.elevation(fp[:, 0], fp[:, 1])
    area = covered.sum() * cell * cell
    centre = fp.mean(axis=0)
    z_sea = float(seabed.elevation(centre[0], centre[1]))
    z_top = float(max(bx.top for bx in reef.boxes))
    rect = min_area_rectangle(corners)
    hull = convex_hull(corners)
    height = z_top - z_sea
    return {
        "id": reef.id, "group": reef.group, "kind": reef.kind,
        "x": float(centre[0] + origin[0]), "y": float(centre[1] + origin[1]),
        "z_seabed": z_sea, "z_top": z_top, "height": height, "area": float(area),
        "length": rect.length, "width": rect.width, "orientation_deg": rect.bearing_deg,
        "volume": float(np.sum(np.maximum(top[covered] - sea, 0.0)) * cell * cell),
        "envelope_volume": rect.length * rect.width * height,
        "bearing_deg": reef.bearing_deg % 360.0,
        "orientation": reef.orientation, "overturned": reef.orientation != "upright",
        "top_tilt_deg": reef.tilt_deg,
        "outline": (hull + np.array(origin)).round(4).tolist(),
        "boxes": [dict(dataclasses.asdict(bx), cx=bx.cx + origin[0], cy=bx.cy + origin[1])
                  for bx in reef.boxes],
    }


def reef_reference_rows(truth: dict[str, Any], *, sigma: float = 0.15, seed: int = 0
                        ) -> list[tuple[float, float, int]]:
    """A truth's reef positions as a surveyor would digitise them (x, y, id), with ``sigma`` m
    scatter."""
    rng = np.random.default_rng(seed)
    return [(r["x"] + rng.normal(0, sigma), r["y"] + rng.normal(0, sigma), r["id"]) for r in truth["reefs"]]


def truth_spacings(piles: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Every pair's plan distance, as truth files hold it: ``{"a", "b", "distance"}``.

    Examples
    --------
    >>> truth_spacings([{"id": 1, "x": 0.0, "y": 0.0}, {"id": 2, "x": 3.0, "y": 4.0}])
    [{'a': 1, 'b': 2, 'distance': 5.0}]
    """
    return [{"a": a["id"], "b": b["id"], "distance": math.hypot(a["x"] - b["x"], a["y"] - b["y"])}
            for a, b in itertools.combinations(piles, 2)]


def scene_truth(preset: str, seed: int, opt: Any, sonar: Sonar, scene: Scene, labels: np.ndarray,
           extra: dict[str, Any]) -> dict[str, Any]:
    ox, oy = scene.origin
    piles = []
    groups_of = {d["id"]: d.get("group", 1) for d in extra.get("design", [])}
    for i, p in enumerate(scene.piles):
        piles.append({"id": i + 1, "x": p.x + ox, "y": p.y + oy, "z": p.top_z,
                      "radius": p.radius, "tilt_deg": p.tilt_deg,
                      "tilt_azimuth_deg": p.tilt_bearing_deg % 360.0, "group": groups_of.get(i + 1, 1),
                      "seabed_z": float(scene.seabed.elevation(p.x, p.y))})
    spacings = truth_spacings(piles)
    reefs = [reef_truth(r, scene.seabed, scene.origin) for r in scene.reefs]
    groups = []
    for g in sorted({r.group for r in scene.reefs}):
        members = [t for t in reefs if t["group"] == g]
        outline = convex_hull(np.concatenate([np.asarray(t["outline"]) for t in members]))
        groups.append({"id": g, "count": len(members),
                       "x": float(np.mean([t["x"] for t in members])),
                       "y": float(np.mean([t["y"] for t in members])),
                       "area": polygon_area(outline), "kind": members[0]["kind"]})
    close = []
    for a, b in itertools.combinations(scene.reefs, 2):
        if math.hypot(a.x - b.x, a.y - b.y) < 6:
            gap = reef_gap(a, b)
            if gap < 1.0:
                close.append({"a": a.id, "b": b.id, "gap": gap})
    distractors = (
        [{"kind": "boulder", "x": b.x + ox, "y": b.y + oy, "z_top": b.z + b.radius,
          "radius": b.radius} for b in scene.boulders if not b.rock]
        + rock_truth(scene)
        + [{"kind": "debris", "x": d.cx + ox, "y": d.cy + oy, "z_top": d.z0 + d.height,
            "length": d.length, "width": d.width} for d in scene.debris]
    )
    counts = {name: int(np.sum(labels == code)) for name, code in LABELS.items()}
    return {
        "preset": preset, "seed": seed,
        "options": dataclasses.asdict(opt), "sonar": dataclasses.asdict(sonar),
        "origin": [ox, oy], "n_soundings": int(len(labels)), "counts": counts,
        "seabed": scene.seabed.to_dict(),
        "piles": piles, "spacings": spacings, **extra,
        "reefs": reefs, "groups": groups, "close_pairs": close, "distractors": distractors,
    }


def rock_truth(scene: Scene) -> list[dict[str, Any]]:
    """One record per rock (its lobes together): centre of its lobes, top, plan size, proud height."""
    ox, oy = scene.origin
    out = []
    for rid in sorted({b.rock for b in scene.boulders if b.rock}):
        lobes = [b for b in scene.boulders if b.rock == rid]
        top = max(b.z + float(b.axes[2]) for b in lobes)
        main = lobes[0]
        out.append({"kind": "rock", "id": rid, "x": main.x + ox, "y": main.y + oy, "z_top": top,
                    "height": top - float(scene.seabed.elevation(main.x, main.y)),
                    "size": 2 * max(float(b.axes[:2].max()) + math.hypot(b.x - main.x, b.y - main.y)
                                    for b in lobes), "lobes": len(lobes)})
    return out


#: How far beyond a unit's outline (m) the seabed round it is read for its exposed height:
#: the middle of the ring of soundings the pipeline reads it from (six 0.1 m cells).
ROUND = 0.3


def exposed_height(truth: dict[str, Any], seabed: Seabed, origin: tuple[float, float]) -> float:
    """A unit's true exposed height for change: its top above the seabed round it. The
    undisturbed seabed at its centre, lowered by the pits' mean lowering on a ring
    :data:`ROUND` m beyond its outline: the seabed under a unit is never sounded, so a pit
    hidden beneath it (its exposed height as the scene's truth states it) is no change a
    survey can see, while a pit round it is.

    Examples
    --------
    >>> from mbinspect.simulate.scene import Seabed
    >>> square = [[-1.5, -1.5], [1.5, -1.5], [1.5, 1.5], [-1.5, 1.5]]
    >>> t = {"x": 0.0, "y": 0.0, "z_top": -18.0, "outline": square}
    >>> hidden = Seabed(z0=-20.0, roughness=0.0, pits=((0.0, 0.0, 0.5, 1.0),))  # under the unit
    >>> round(exposed_height(t, hidden, (0.0, 0.0)), 3)
    2.0
    >>> wide = Seabed(z0=-20.0, roughness=0.0, pits=((0.0, 0.0, 0.5, 6.0),))  # round it too
    >>> 2.2 < exposed_height(t, wide, (0.0, 0.0)) < 2.5
    True
    """
    ox, oy = origin
    ring = _perimeter(grown(np.asarray(truth["outline"], np.float64) - (ox, oy), ROUND), 0.05)
    plain = dataclasses.replace(seabed, pits=())
    lowering = plain.elevation(ring[:, 0], ring[:, 1]) - seabed.elevation(ring[:, 0], ring[:, 1])
    x, y = truth["x"] - ox, truth["y"] - oy
    return float(truth["z_top"] - (float(plain.elevation(x, y)) - float(np.mean(lowering))))


def _perimeter(poly: np.ndarray, step: float) -> np.ndarray:
    """Points every ``step`` m or closer along a closed polygon's edges."""
    ends = np.roll(poly, -1, axis=0)
    counts = np.maximum(1, np.ceil(np.hypot(*(ends - poly).T) / step)).astype(int)
    return np.concatenate([a + (b - a) * (np.arange(n) / n)[:, None]
                           for a, b, n in zip(poly, ends, counts, strict=True)])
