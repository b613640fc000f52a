"""Each preset's scene and survey lines built from its options."""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from ..checks import fail
from ..design_solids import distinct_orientations
from ..errors import ParameterError
from ..geometry import (
    bearing_to_vector,
)
from ..reef_designs import BUILTIN_DESIGNS
from .presets import (
    JacketOptions,
    ReefFieldOptions,
    WharfOptions,
    rakes,
)
from .scene import Boulder, Box, Pile, Reef, Scene, Seabed, reef_boxes, reef_gap
from .sonar import Line, Sonar, Survey


def build_jacket(opt: JacketOptions, rng: np.random.Generator, sonar: Sonar
            ) -> tuple[Scene, Survey, dict[str, Any]]:
    h = opt.side / 2
    seabed = Seabed(z0=opt.seabed, slope_deg=opt.slope_deg, slope_bearing_deg=rng.uniform(0, 360),
                    sand_wave_amplitude=opt.sand_wave_amplitude, roughness=opt.roughness,
                    extent=opt.line_extent + opt.line_offset + 60, seed=int(rng.integers(2**31)))
    design = [(-h, -h), (h, -h), (-h, h), (h, h)]  # ids 1..4: SW, SE, NW, NE
    piles = []
    for dx, dy in design:
        off = rng.normal(0.0, opt.position_scatter, 2)
        piles.append(Pile(dx + off[0], dy + off[1], opt.top + rng.normal(0, opt.top_scatter),
                          opt.radius, tilt_deg=rng.uniform(0, opt.tilt_max_deg),
                          tilt_bearing_deg=rng.uniform(0, 360), bottom_z=opt.seabed - 15))
    boulders = []
    for _ in range(opt.boulders):
        while True:
            p = rng.uniform(-h - 8, h + 8, 2)
            if min(math.hypot(p[0] - q.x, p[1] - q.y) for q in piles) > 4:
                break
        r = rng.uniform(0.3, 0.6)
        boulders.append(Boulder(p[0], p[1], float(seabed.elevation(p[0], p[1])) - 0.3 * r, r))
    e, o = opt.line_extent, h + opt.line_offset
    catalogue = {
        "west": [((-o, -e), (-o, e))], "east": [((o, e), (o, -e))],
        "south": [((e, -o), (-e, -o))], "north": [((-e, o), (e, o))],
        "tops": [((-h, -e), (-h, e)), ((h, e), (h, -e))],
        "tops-ew": [((-e, -h), (e, -h)), ((e, h), (-e, h))],
    }
    lines = []
    for name in [s.strip() for s in opt.lines.split(",") if s.strip()]:
        if name not in catalogue:
            raise fail("lines", name, f"one of {', '.join(catalogue)}")
        lines += [Line(v, ping_spacing=opt.ping_spacing) for v in catalogue[name]]
    scene = Scene(seabed, tuple(piles), boulders=tuple(boulders),
                  origin=(opt.origin_x, opt.origin_y))
    extra = {"design": [{"id": i + 1, "x": dx + opt.origin_x, "y": dy + opt.origin_y, "top": opt.top}
                        for i, (dx, dy) in enumerate(design)]}
    return scene, Survey(tuple(lines), sonar), extra




def build_wharf(opt: WharfOptions, rng: np.random.Generator, sonar: Sonar
           ) -> tuple[Scene, Survey, dict[str, Any]]:
    jacket_rakes = rakes(opt.rakes)
    pitch = opt.side + opt.gap
    h = opt.side / 2
    half = (len(jacket_rakes) - 1) * pitch / 2 + h
    seabed = Seabed(z0=opt.seabed, slope_deg=opt.slope_deg, slope_bearing_deg=rng.uniform(0, 360),
                    roughness=opt.roughness, extent=half + opt.line_offset + 60,
                    seed=int(rng.integers(2**31)))
    piles: list[Pile] = []
    design: list[dict[str, Any]] = []
    for g, rake in enumerate(jacket_rakes):
        cx = -(len(jacket_rakes) - 1) * pitch / 2 + g * pitch
        tilt = math.degrees(math.atan(1.0 / rake)) if rake else 0.0
        for dx, dy in ((-h, -h), (h, -h), (-h, h), (h, h)):
            off = rng.normal(0.0, opt.position_scatter, 2)
            outward = math.degrees(math.atan2(dx, dy)) % 360.0
            piles.append(Pile(cx + dx + off[0], dy + off[1], opt.top + rng.normal(0, opt.top_scatter),
                              opt.radius, tilt_deg=tilt, tilt_bearing_deg=outward, bottom_z=opt.seabed - 15))
            design.append({"group": g + 1, "id": len(design) + 1, "x": cx + dx + opt.origin_x,
                           "y": dy + opt.origin_y, "top": opt.top, "tilt_deg": tilt,
                           "tilt_azimuth_deg": outward if tilt else 0.0})
    e, o = half + 25.0, h + opt.line_offset
    lines = [Line(((-e, -o), (e, -o)), ping_spacing=opt.ping_spacing),
             Line(((e, o), (-e, o)), ping_spacing=opt.ping_spacing),
             Line(((-e, -h), (e, -h)), ping_spacing=opt.ping_spacing),
             Line(((e, h), (-e, h)), ping_spacing=opt.ping_spacing)]
    scene = Scene(seabed, tuple(piles), origin=(opt.origin_x, opt.origin_y))
    jackets = [{"group": g + 1, "rake": r} for g, r in enumerate(jacket_rakes)]
    return scene, Survey(tuple(lines), sonar), {"design": design, "jackets": jackets}


def build_reef_field(opt: ReefFieldOptions, rng: np.random.Generator, sonar: Sonar
                     ) -> tuple[Scene, Survey, dict[str, Any]]:
    """The ``reef-field`` scene (groups of reefs on a square grid, jittered; chosen
    neighbours brought close or into contact; boulders, debris and rocks among them) and
    its parallel lines.

    Parameters
    ----------
    opt : ReefFieldOptions
    rng : Generator
        The scene's randomness.
    sonar : Sonar

    Returns
    -------
    scene : Scene
    survey : Survey
    extra : dict
        Nothing more for the truth.
    """
    kinds = [s.strip() for s in opt.groups.split(",") if s.strip()]
    if not kinds:
        raise ParameterError("groups: no reef group given; expected e.g. cross2,cross1")
    cols = int(math.ceil(math.sqrt(len(kinds))))
    rows = int(math.ceil(len(kinds) / cols))
    seabed = Seabed(z0=opt.seabed, slope_deg=opt.slope_deg, slope_bearing_deg=rng.uniform(0, 360),
                    sand_wave_amplitude=opt.sand_wave_amplitude,
                    sand_wave_length=opt.sand_wave_length,
                    sand_wave_bearing_deg=rng.uniform(0, 180), roughness=opt.roughness,
                    extent=opt.group_spacing * max(rows, cols) / 2 + 90,
                    seed=int(rng.integers(2**31)))
    # one sink per reef id, drawn up front so that a reef rebuilt for the shore (below) keeps
    # its own; the table's size bounds the ids, not the field (ids stay in the hundreds)
    sunk = rng.uniform(0.0, opt.burial_max, 10_000) if opt.burial_max > 0 else np.zeros(10_000)
    rest = _Rest(sunk, *_poses(opt, len(kinds) * opt.per_group, rng))
    make = functools.partial(_make_reef, seabed, rest, opt.reef_scale)
    nominal: dict[int, tuple[float, float, float | None]] = {}
    reefs = _place_groups(kinds, cols, rows, opt, rng, make, nominal)
    _bring_together(reefs, opt, rng, make)
    xy = np.array([[r.x, r.y] for r in reefs])
    lo, hi = xy.min(axis=0) - 12, xy.max(axis=0) + 12
    if opt.shore_width > 0:
        seabed = dataclasses.replace(seabed, shore_start=float(hi[1]) + 3.0,
                                     shore_width=opt.shore_width)
        make = functools.partial(_make_reef, seabed, rest, opt.reef_scale)
        reefs = [make(r.id, r.kind, r.x, r.y, r.bearing_deg, r.group) for r in reefs]
    survey_hi = hi + np.array([0.0, opt.shore_width])
    boulders, debris = _distractors(opt, rng, seabed, lo, hi, xy)
    boulders += _rocks(opt.rocks, rng, seabed, lo, hi, xy, first=len(boulders) + 1)
    lines = []
    y0, y1 = lo[1] - 10, survey_hi[1] + 10
    n_lines = int(math.ceil((y1 - y0) / opt.line_spacing)) + 1
    for k in range(n_lines):
        y = y0 + k * opt.line_spacing
        xs = (lo[0] - 15, hi[0] + 15) if k % 2 == 0 else (hi[0] + 15, lo[0] - 15)
        lines.append(Line(((xs[0], y), (xs[1], y)), ping_spacing=opt.ping_spacing))
    scene = Scene(seabed, reefs=tuple(reefs), boulders=tuple(boulders), debris=tuple(debris),
                  origin=(opt.origin_x, opt.origin_y))
    # the deployment plan: each unit's nominal place and, when one was set, its bearing
    kinds_of = {r.id: r.kind for r in reefs}
    plan = [{"id": rid, "x": x + opt.origin_x, "y": y + opt.origin_y, "bearing_deg": b, "kind": kinds_of[rid]}
            for rid, (x, y, b) in sorted(nominal.items())]
    return scene, Survey(tuple(lines), sonar), {"plan": plan}


@dataclasses.dataclass(frozen=True)
class _Rest:
    """How each reef id comes to rest: its burial, orientation and lean (tables by id)."""

    sunk: np.ndarray
    overturned: dict[int, str]
    tilt: np.ndarray
    tilt_bearing: np.ndarray


def _poses(opt: ReefFieldOptions, n: int, rng: np.random.Generator
           ) -> tuple[dict[int, str], np.ndarray, np.ndarray]:
    """Which reef ids lie overturned (and how: one of their kind's distinct orientations),
    and each id's lean; drawn only when asked, so that other scenes keep their randomness."""
    zeros = np.zeros(10_000)
    if not (opt.overturned or opt.tilt_max_deg):
        return {}, zeros, zeros
    sub = np.random.default_rng(int(rng.integers(2**31)))
    ids = sub.choice(np.arange(1, n + 1), size=min(opt.overturned, n), replace=False)
    ways = [str(w) for w in sub.integers(0, 1_000_000, len(ids))]
    tilt = sub.uniform(0.0, opt.tilt_max_deg, 10_000) if opt.tilt_max_deg else zeros
    return dict(zip(ids.tolist(), ways, strict=True)), tilt, sub.uniform(0.0, 360.0, 10_000)


def _make_reef(seabed: Seabed, rest: _Rest, scale: float, rid: int, kind: str, x: float, y: float,
               b: float, g: int) -> Reef:
    """A reef resting on the seabed at (x, y), sunk 0.1 m and its own further burial, in
    its orientation and lean."""
    z = float(seabed.elevation(x, y)) - 0.1 - float(rest.sunk[rid % len(rest.sunk)])
    way = "upright"
    if rid in rest.overturned:
        ways = [w for w in distinct_orientations(BUILTIN_DESIGNS[kind]) if w != "upright"]
        way = ways[int(rest.overturned[rid]) % len(ways)] if ways else "upright"
    tilt, toward = float(rest.tilt[rid % len(rest.tilt)]), float(rest.tilt_bearing[rid % len(rest.tilt)])
    return Reef(rid, kind, x, y, b, reef_boxes(kind, x, y, b, z, scale, way, tilt, toward), group=g,
                orientation=way, tilt_deg=tilt, tilt_bearing_deg=toward)


def _place_groups(kinds: list[str], cols: int, rows: int, opt: ReefFieldOptions, rng: np.random.Generator,
                  make: Callable[..., Reef], nominal: dict[int, tuple[float, float, float | None]]
                  ) -> list[Reef]:
    """Each group's reefs on a square grid, jittered, kept 1.2 m apart; each one's grid
    place (and planned bearing) into ``nominal``."""
    side = int(math.ceil(math.sqrt(opt.per_group)))
    reefs: list[Reef] = []
    for g, kind in enumerate(kinds):
        gx = (g % cols - (cols - 1) / 2) * opt.group_spacing
        gy = ((rows - 1) / 2 - g // cols) * opt.group_spacing
        for k in range(opt.per_group):
            place = (gx + (k % side - (side - 1) / 2) * opt.grid_spacing,
                     gy + (k // side - (side - 1) / 2) * opt.grid_spacing)
            kk = kind if kind != "mixed" else ("cross2", "cross1", "hollow", "triangle")[k % 4]
            planned = opt.plan_bearing_deg
            for _ in range(200):
                x, y = np.asarray(place) + rng.normal(0.0, opt.jitter, 2)
                turn = rng.uniform(0, 90) if planned is None else rng.normal(0.0, opt.bearing_scatter_deg)
                b = turn if planned is None else planned + turn
                cand = make(len(reefs) + 1, kk, x, y, b, g + 1)
                if all(reef_gap(cand, r) > 1.2 for r in reefs
                       if math.hypot(r.x - x, r.y - y) < 8):
                    break
            reefs.append(cand)
            nominal[cand.id] = (float(place[0]), float(place[1]), planned)
    return reefs


def _bring_together(reefs: list[Reef], opt: ReefFieldOptions, rng: np.random.Generator,
                    make: Callable[..., Reef]) -> None:
    """Chosen neighbour pairs brought close together (0.3-0.9 m) or into contact, in place."""
    targets = [(rng.uniform(0.3, 0.9)) for _ in range(opt.close_pairs)]
    targets += [0.0] * opt.touching_pairs
    moved: set[int] = set()
    for target in targets:
        order = rng.permutation(len(reefs))
        for i in order:
            if i in moved:
                continue
            a = reefs[i]
            near = [j for j in range(len(reefs)) if j != i and j not in moved
                    and reefs[j].group == a.group
                    and math.hypot(reefs[j].x - a.x, reefs[j].y - a.y) < opt.grid_spacing * 1.5]
            if not near:
                continue
            j = min(near, key=lambda j: math.hypot(reefs[j].x - a.x, reefs[j].y - a.y))
            new = _moved_to_gap(a, reefs[j], target, make)
            others = [r for k2, r in enumerate(reefs) if k2 not in (i, j)
                      and math.hypot(r.x - new.x, r.y - new.y) < 8]
            if all(reef_gap(new, r) > 1.0 for r in others):
                reefs[j] = new
                moved.update((i, j))
                break


def _moved_to_gap(a: Reef, b: Reef, target: float, make: Callable[..., Reef]) -> Reef:
    """``b`` moved toward ``a`` until the gap between them is ``target`` (0: touching)."""
    v = np.array([a.x - b.x, a.y - b.y])
    dist = float(np.hypot(*v))
    v /= dist

    def at(s: float) -> Reef:
        return make(b.id, b.kind, b.x + s * v[0], b.y + s * v[1], b.bearing_deg, b.group)

    lo, hi = 0.0, dist
    for _ in range(40):
        mid = (lo + hi) / 2
        if reef_gap(a, at(mid)) > target:
            lo = mid
        else:
            hi = mid
    return at(lo if target > 0 else hi)


def _distractors(opt: ReefFieldOptions, rng: np.random.Generator, seabed: Seabed, lo: np.ndarray,
                 hi: np.ndarray, xy: np.ndarray) -> tuple[list[Boulder], list[Box]]:
    """Boulders and debris among the reefs, 4.5 m or more from every reef centre."""
    boulders: list[Boulder] = []
    debris: list[Box] = []
    for n_items, is_boulder in ((opt.boulders, True), (opt.debris, False)):
        for _ in range(n_items):
            for _ in range(500):
                p = rng.uniform(lo, hi)
                if np.min(np.hypot(*(xy - p).T)) > 4.5:
                    break
            z = float(seabed.elevation(p[0], p[1]))
            if is_boulder:
                r = rng.uniform(0.25, 0.5)
                boulders.append(Boulder(p[0], p[1], z - 0.3 * r, r))
            else:
                debris.append(Box(p[0], p[1], z - 0.05, rng.uniform(0.5, 1.2),
                                  rng.uniform(0.3, 0.6), rng.uniform(0.2, 0.5),
                                  rng.uniform(0, 180)))
    return boulders, debris


def _rocks(n: int, rng: np.random.Generator, seabed: Seabed, lo: np.ndarray, hi: np.ndarray,
           reefs_xy: np.ndarray, first: int) -> list[Boulder]:
    """``n`` rounded rocks of reef size, each an ellipsoid sunk so that 0.4-1.5 m shows, a
    third of them with a second, smaller lobe (numbered ``first``, ``first + 1``, ...)."""
    if n == 0:
        return []
    rng = np.random.default_rng(rng.integers(2**63))  # its own stream: other scenes stay as they were
    out: list[Boulder] = []
    for k in range(n):
        for _ in range(500):
            p = rng.uniform(lo, hi)
            if np.min(np.hypot(*(reefs_xy - p).T)) > 4.5 and all(
                    math.hypot(b.x - p[0], b.y - p[1]) > 4.0 for b in out):
                break
        a = rng.uniform(0.6, 1.3)
        proud = rng.uniform(0.4, 1.5)
        rz = proud / rng.uniform(0.6, 0.9)
        bearing = rng.uniform(0, 180)
        z = float(seabed.elevation(p[0], p[1])) + proud - rz
        out.append(Boulder(p[0], p[1], z, a, ry=a * rng.uniform(0.6, 1.0), rz=rz, bearing_deg=bearing,
                           rock=first + k))
        if rng.random() < 1 / 3:
            u = bearing_to_vector(bearing) * a * rng.uniform(0.7, 1.0)
            s = rng.uniform(0.6, 0.8)
            out.append(Boulder(p[0] + u[0], p[1] + u[1], z - rz * (1 - s) * 0.5, a * s, ry=a * s * 0.8,
                               rz=rz * s, bearing_deg=bearing + rng.uniform(-40, 40), rock=first + k))
    return out
