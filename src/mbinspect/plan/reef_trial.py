"""One candidate layout over a reef plan, surveyed in the simulator and measured as a user
would: a reef trial.

The scene is the plan alone: each unit built to its design at its planned place and bearing
(a unit whose plan gives no bearing lies at a random one), settled :data:`SETTLE` into a
rough seabed at the planned depth. When the S-44 order asks for feature detection, cubes of
the order's size are laid at random over the area the lines cover, on the same seabed, and
surveyed by the same lines in a scene of their own (no cube hides a unit or is taken for
one). The survey sails the layout's lines with the sonar's beam and error model;
:func:`~mbinspect.reefs.extract_reefs` measures the soundings with the units' designs (told
the beam and taking its bloom off, as for any sonar of finite beams) and places them against
the plan. A trial keeps, for each unit, whether a reef was found in its place, the soundings
that fell on it, and its height and centre errors against the truth; for each cube, the
soundings that fell on it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import DataError
from ..reefs import extract_reefs
from ..reefs.plan import ReefPlan
from ..simulate import LABELS, Box, Line, Reef, Scene, Seabed, Sonar, Survey, reef_boxes, reef_truth, survey
from .layouts import Layout

__all__ = ["PlannedUnit", "ReefSetting", "ReefTrial", "run_reef_trial", "CLEAR"]

#: Units settle this far (m) into the seabed, as the simulator's reef fields lay them.
SETTLE = 0.1

#: A feature cube's corners lie at least this far (m) beyond a unit's reach from its centre.
CLEAR = 1.0


@dataclass(frozen=True)
class PlannedUnit:
    """A unit of the reef plan: id, planned centre (the plan's CRS), bearing (None: not planned)
    and design, and its reach: the largest distance from its centre to its outline (m)."""

    id: str
    x: float
    y: float
    bearing_deg: float | None
    kind: str
    reach: float


@dataclass(frozen=True)
class ReefSetting:
    """What every reef trial shares: the sonar, ping spacing (m), speed (m/s), depth (m), the
    local origin, the area the cubes are laid in (local xmin, ymin, xmax, ymax), the cube's
    size (m, None: no cubes) and how many."""

    sonar: Sonar
    ping_spacing: float
    speed: float
    depth: float
    origin: tuple[float, float]
    area: tuple[float, float, float, float]
    cube: float | None
    cubes: int


@dataclass(frozen=True)
class ReefTrial:
    """One simulated survey of one layout: per unit ``(id, found, soundings, height error,
    centre error)`` (errors NaN when not found), the soundings on each cube, and in all."""

    layout: str
    seed: int
    units: tuple[tuple[str, bool, int, float, float], ...]
    cubes: tuple[int, ...]
    soundings: int


def _cubes(s: ReefSetting, rng: np.random.Generator) -> tuple[tuple[float, float], ...]:
    """Centres of ``s.cubes`` cubes of ``s.cube`` m at random in the area, each clear of the
    others by :data:`CLEAR` and a cube."""
    if s.cube is None or s.cubes == 0:
        return ()
    placed: list[tuple[float, float]] = []
    x0, y0, x1, y1 = s.area
    for _ in range(200 * s.cubes):
        if len(placed) == s.cubes:
            break
        p = rng.uniform((x0, y0), (x1, y1))
        if all(math.dist(p, q) > s.cube * math.sqrt(2.0) + CLEAR for q in placed):
            placed.append((float(p[0]), float(p[1])))
    return tuple(placed)


def _scenes(units: tuple[PlannedUnit, ...], s: ReefSetting, rng: np.random.Generator
            ) -> tuple[Scene, Scene | None, dict[str, dict[str, Any]]]:
    """The units on the seabed, the cubes on the same seabed (None: no cubes), and each unit's truth."""
    seabed = Seabed(z0=-s.depth, roughness=0.03, extent=max(abs(v) for v in s.area) + 60.0,
                    seed=int(rng.integers(2**31)))
    reefs, truth = [], {}
    for k, u in enumerate(units):
        x, y = u.x - s.origin[0], u.y - s.origin[1]
        bearing = u.bearing_deg if u.bearing_deg is not None else float(rng.uniform(0.0, 360.0))
        boxes = reef_boxes(u.kind, x, y, bearing, float(seabed.elevation(x, y)) - SETTLE)
        reef = Reef(k + 1, u.kind, x, y, bearing, boxes)
        reefs.append(reef)
        truth[u.id] = reef_truth(reef, seabed, s.origin)
    size = s.cube or 0.0
    cubes = tuple(Box(cx, cy, float(seabed.elevation(cx, cy)), size, size, size, float(rng.uniform(0, 90)))
                  for cx, cy in _cubes(s, rng))
    return (Scene(seabed, reefs=tuple(reefs), origin=s.origin),
            Scene(seabed, debris=cubes, origin=s.origin) if cubes else None, truth)


def run_reef_trial(layout: Layout, units: tuple[PlannedUnit, ...], setting: ReefSetting, seed: int
                   ) -> ReefTrial:
    """Survey ``layout`` over the plan's units with ``seed`` and measure them."""
    rng = np.random.default_rng([seed, 11])
    ox, oy = setting.origin
    scene, cube_scene, truth = _scenes(units, setting, rng)
    lines = tuple(Line(((ln.start[0] - ox, ln.start[1] - oy), (ln.end[0] - ox, ln.end[1] - oy)),
                       ping_spacing=setting.ping_spacing, speed=setting.speed) for ln in layout.lines)
    seed_survey = int(rng.integers(2**31))
    cloud, label, ident = survey(scene, Survey(lines, setting.sonar), seed=seed_survey)
    on_reef = np.bincount(ident[label == LABELS["reef"]], minlength=len(units) + 1)
    on_cube = np.zeros(1, np.int64)
    if cube_scene is not None:  # the same survey over the cubes alone: no cube hides or is taken for a unit
        _, c_label, c_ident = survey(cube_scene, Survey(lines, setting.sonar), seed=seed_survey)
        on_cube = np.bincount(c_ident[c_label == LABELS["debris"]], minlength=len(cube_scene.debris) + 1)
    plan = ReefPlan(tuple({"id": u.id, "x": u.x, "y": u.y, "bearing_deg": u.bearing_deg, "kind": u.kind,
                           "group": None} for u in units), "planned units")
    # a sonar of finite beams is measured as the README tells for one: the beam told, its bloom taken off
    beam: dict[str, Any] = {"beam_width_deg": setting.sonar.beam_across_deg, "beam_correction": True} \
        if setting.sonar.beam_across_deg > 0 else {}
    try:
        res = extract_reefs(cloud, design=",".join(sorted({u.kind for u in units})), plan=plan, seed=seed,
                            **beam)
        placed = {r.plan.get("plan_id"): r for r in res.reefs if r.plan.get("plan_id") is not None}
    except DataError:
        placed = {}
    rows = []
    for k, u in enumerate(units):
        r, t = placed.get(u.id), truth[u.id]
        rows.append((u.id, r is not None, int(on_reef[k + 1]),
                     float(r.height - t["height"]) if r is not None else math.nan,
                     float(math.hypot(r.x - t["x"], r.y - t["y"])) if r is not None else math.nan))
    return ReefTrial(layout.name, seed, tuple(rows), tuple(int(c) for c in on_cube[1:]), len(cloud))
