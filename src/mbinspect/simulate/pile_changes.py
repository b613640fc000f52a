"""Piles changed between two surveys, for :func:`~mbinspect.simulate.resurvey.resurvey`:
a pile settles (driven deeper along its axis), leans (turning about where it enters the
seabed, so its top moves) and has a scour pit dug round it; and the true change of each.

A pile is the ``id`` the truth gives it (its place in the scene, from 1). Piles are not
moved, turned, overturned, removed or added here: a change saying so is refused.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..errors import ParameterError
from ..geometry import bearing_to_vector, tilted_section
from .scene import Pile, Scene

__all__ = ["changed_piles", "true_pile_changes", "check_pile_change"]


def check_pile_change(c: Any) -> None:
    """Refuse what a pile cannot do here (a :class:`ParameterError` naming the field)."""
    if c.status != "changed":
        raise ParameterError(f"status: {c.status!r} for pile {c.id}; expected changed (piles are not "
                             "removed or added by the simulator)", option="status")
    for name in ("dx", "dy", "rotation_deg"):
        if getattr(c, name) != 0:
            raise ParameterError(f"{name}: {getattr(c, name)} for pile {c.id}; expected 0 (a pile's top "
                                 "moves by leaning: give tilt_deg and tilt_bearing_deg)", option=name)
    if c.orientation is not None or c.kind:
        raise ParameterError(f"orientation, kind: given for pile {c.id}; expected neither for a pile",
                             option="orientation")


def changed_piles(scene: Scene, changes: Sequence[Any]) -> Scene:
    """The scene with each pile settled, leaning anew and scoured round as ``changes`` say."""
    by_id = {c.id: c for c in changes}
    piles, pits = [], []
    for i, p in enumerate(scene.piles):
        c = by_id.get(i + 1)
        if c is None:
            piles.append(p)
            continue
        piles.append(_moved(p, c, float(scene.seabed.elevation(p.x, p.y))))
        if c.scour_depth > 0:  # round the foot, where the pile meets the seabed
            fx, fy = _foot(p, float(scene.seabed.elevation(p.x, p.y)))
            pits.append((fx, fy, c.scour_depth, c.scour_radius))
    seabed = dataclasses.replace(scene.seabed, pits=scene.seabed.pits + tuple(pits)) if pits else scene.seabed
    return dataclasses.replace(scene, seabed=seabed, piles=tuple(piles))


def _foot(p: Pile, seabed_z: float) -> tuple[float, float]:
    """Where the pile's axis meets the seabed's height (local x, y)."""
    axis = p.axis
    foot = np.array([p.x, p.y, p.top_z]) - axis * (p.top_z - seabed_z) / axis[2]
    return float(foot[0]), float(foot[1])


def _moved(p: Pile, c: Any, seabed_z: float) -> Pile:
    """The pile driven ``settlement`` deeper along its axis and leaning as ``c`` says, turned
    about the point where its axis meets the seabed."""
    axis = p.axis
    length = (p.top_z - seabed_z) / axis[2]  # top to seabed along the axis
    foot = np.array([p.x, p.y, p.top_z]) - axis * length
    tilt = p.tilt_deg if c.tilt_deg is None else c.tilt_deg
    toward = p.tilt_bearing_deg if c.tilt_bearing_deg is None else c.tilt_bearing_deg
    h = bearing_to_vector(toward) * math.sin(math.radians(tilt))
    new_axis = np.array([h[0], h[1], math.cos(math.radians(tilt))])
    top = foot + new_axis * (length - c.settlement)
    return dataclasses.replace(p, x=float(top[0]), y=float(top[1]), top_z=float(top[2]), tilt_deg=tilt,
                               tilt_bearing_deg=toward, bottom_z=p.bottom_z - c.settlement)


def true_pile_changes(before: Scene, after: Scene, changes: Sequence[Any], origin: tuple[float, float]
                      ) -> list[dict[str, Any]]:
    """Per pile, its true change in the before survey's frame: the top centre's ``dx``,
    ``dy``, ``displacement``, the top's ``settlement`` (positive down), the tilt before and
    after and its change, and the scour every pit of the scene leaves round the pile's foot
    (its section at the seabed; as :func:`~mbinspect.scour.pit_scour` reads it)."""
    from ..scour import pit_scour

    by_id = {c.id: c for c in changes}
    dug = [(x + origin[0], y + origin[1], d, r) for x, y, d, r in after.seabed.pits[len(before.seabed.pits):]]
    feet = [(x + origin[0], y + origin[1]) for x, y in
            (_foot(p, float(after.seabed.elevation(p.x, p.y))) for p in after.piles)]
    sections = [tilted_section(f, p.radius, p.tilt_deg, p.tilt_bearing_deg, 48)
                for p, f in zip(after.piles, feet, strict=True)]
    out = []
    for i, (pb, pa) in enumerate(zip(before.piles, after.piles, strict=True)):
        dx, dy = pa.x - pb.x, pa.y - pb.y
        c = by_id.get(i + 1)
        scour = pit_scour(dug, sections[i], feet[i], others=sections[:i] + sections[i + 1:])
        out.append({"id": i + 1, "status": "changed" if c is not None else "unchanged",
                    "x_before": pb.x + origin[0], "y_before": pb.y + origin[1], "x_after": pa.x + origin[0],
                    "y_after": pa.y + origin[1], "dx": dx, "dy": dy, "displacement": math.hypot(dx, dy),
                    "settlement": pb.top_z - pa.top_z, "tilt_before": pb.tilt_deg, "tilt_after": pa.tilt_deg,
                    "tilt_change_deg": pa.tilt_deg - pb.tilt_deg, **scour})
    return out
