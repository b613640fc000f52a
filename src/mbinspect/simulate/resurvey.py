"""A scene surveyed again after it changed: the truth of change between two surveys.

:func:`resurvey` rebuilds the scene a ``truth.json`` describes (its preset, seed and
options), moves, turns, sinks, tilts, overturns or removes reefs and adds new ones as a
list of :class:`Change` says, digs scour pits around them, and sails it again with other
lines (shifted across the track and sailed the other way), other noise (its own seed) and a
datum and position offset of the whole survey (``shift``). Its truth holds the scene as
surveyed and ``change``: the offset and, per reef, the true change in the before survey's
frame.
"""

from __future__ import annotations

import csv
import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..design_solids import ORIENTATIONS
from ..errors import InputError, ParameterError
from ..io import PointCloud
from .pile_changes import changed_piles, check_pile_change, true_pile_changes
from .run import Simulation, _setup
from .scene import Reef, Scene, reef_boxes
from .sonar import Line, Survey
from .survey import survey
from .truth import exposed_height, reef_truth, scene_truth

__all__ = ["Change", "read_changes", "random_changes", "random_pile_changes", "resurvey", "scour_truth",
           "CHANGE_COLUMNS"]


@dataclass(frozen=True)
class Change:
    """What happened to one reef or pile between the surveys (local metres, degrees).

    ``status`` is ``changed`` (the fields say how), ``removed`` or ``new`` (then ``kind``,
    ``x``, ``y``, ``bearing_deg`` place it in the scene's projected coordinates).
    ``settlement`` lowers the unit (m, positive down); ``orientation``, ``tilt_deg`` and
    ``tilt_bearing_deg``, when given, are how it rests afterwards; a scour pit of
    ``scour_depth`` m and ``scour_radius`` m is dug around it (a cosine bell centred on
    the unit). A pile (:mod:`.pile_changes`) settles, leans and is scoured round only.
    """

    id: int
    status: str = "changed"
    dx: float = 0.0
    dy: float = 0.0
    rotation_deg: float = 0.0
    settlement: float = 0.0
    orientation: str | None = None
    tilt_deg: float | None = None
    tilt_bearing_deg: float | None = None
    scour_depth: float = 0.0
    scour_radius: float = 0.0
    kind: str = ""
    x: float = math.nan
    y: float = math.nan
    bearing_deg: float = 0.0


#: The columns a changes CSV may hold (``id`` is required), with how each is read.
CHANGE_COLUMNS: dict[str, Callable[[str], Any]] = {
    "id": int, "status": str, "dx": float, "dy": float, "rotation_deg": float, "settlement": float,
    "orientation": str, "tilt_deg": float, "tilt_bearing_deg": float, "scour_depth": float,
    "scour_radius": float, "kind": str, "x": float, "y": float, "bearing_deg": float,
}


def read_changes(path: str | Path) -> tuple[Change, ...]:
    """The changes of a CSV file (a header naming :data:`CHANGE_COLUMNS`, ``id`` among them).

    Raises
    ------
    InputError
        A missing file, an unknown column, or a bad value (named by file, line and column).
    """
    p = Path(path)
    try:
        rows = list(csv.reader(p.read_text(encoding="utf-8-sig").splitlines()))
    except FileNotFoundError:
        raise InputError(f"{p}: no such file") from None
    except UnicodeDecodeError as exc:
        raise InputError(f"{p}: not a text CSV ({exc.reason})") from None
    if not rows or "id" not in [h.strip() for h in rows[0]]:
        raise InputError(f"{p}, line 1: expected a header with an 'id' column and any of "
                         f"{', '.join(CHANGE_COLUMNS)}")
    header = [h.strip() for h in rows[0]]
    unknown = [h for h in header if h not in CHANGE_COLUMNS]
    if unknown:
        raise InputError(f"{p}, line 1: column {unknown[0]!r} is unknown; expected any of "
                         f"{', '.join(CHANGE_COLUMNS)}")
    out = []
    for n, row in enumerate(rows[1:], start=2):
        if not any(c.strip() for c in row):
            continue
        values: dict[str, Any] = {}
        for h, text in zip(header, row, strict=False):
            if not text.strip():
                continue
            try:
                values[h] = CHANGE_COLUMNS[h](text.strip())
            except ValueError:
                want = "an integer" if h == "id" else "a number"
                raise InputError(f"{p}, line {n}, column {h}: {text.strip()!r}; expected {want}") from None
        try:
            out.append(checked(Change(**values)))
        except ParameterError as exc:
            raise InputError(f"{p}, line {n}: {exc}") from None
    return tuple(out)


def checked(c: Change) -> Change:
    """The change if it makes sense, else a :class:`ParameterError` naming the field."""
    if c.status not in ("changed", "removed", "new"):
        raise ParameterError(f"status: {c.status!r}; expected changed, removed or new", option="status")
    if c.orientation is not None and c.orientation not in ORIENTATIONS:
        raise ParameterError(f"orientation: {c.orientation!r}; expected one of {', '.join(ORIENTATIONS)}",
                             option="orientation")
    for name in ("dx", "dy", "rotation_deg", "settlement", "scour_depth", "scour_radius"):
        if not math.isfinite(getattr(c, name)):
            raise ParameterError(f"{name}: {getattr(c, name)}; expected a finite number", option=name)
    if c.scour_depth < 0 or c.scour_radius < 0 or (c.scour_depth > 0) != (c.scour_radius > 0):
        raise ParameterError(f"scour_depth, scour_radius: {c.scour_depth}, {c.scour_radius}; expected both "
                             "positive (m) or both zero", option="scour_depth")
    if c.tilt_deg is not None and not 0 <= c.tilt_deg <= 60:
        raise ParameterError(f"tilt_deg: {c.tilt_deg}; expected 0 to 60 degrees", option="tilt_deg")
    if c.status == "new" and (not c.kind or not (math.isfinite(c.x) and math.isfinite(c.y))):
        raise ParameterError("kind, x, y: a new reef needs its kind and its place", option="kind")
    return c


def random_changes(truth: Mapping[str, Any], *, seed: int, share: float = 0.5, move: float = 1.5,
                   settle: float = 0.3, scour: float = 1.0) -> tuple[Change, ...]:
    """Changes for a study: about ``share`` of the reefs changed, each in one way drawn at
    random (moved up to ``move`` m and turned up to 30°, settled 0.05 to ``settle`` m,
    tilted 3 to 12°, overturned, scoured 0.3 to ``scour`` m deep at its centre, or removed), the rest left
    alone, and one new reef placed in the field at least 6 m from the others."""
    rng = np.random.default_rng(seed)
    reefs = list(truth["reefs"])
    out = []
    for r in reefs:
        if rng.random() >= share:
            continue
        way = rng.choice(["move", "settle", "tilt", "overturn", "scour", "remove"])
        rid = int(r["id"])
        if way == "move":
            a, d = rng.uniform(0, 2 * math.pi), rng.uniform(0.2, move)
            out.append(Change(rid, dx=d * math.sin(a), dy=d * math.cos(a), rotation_deg=rng.uniform(-30, 30)))
        elif way == "settle":
            out.append(Change(rid, settlement=rng.uniform(0.05, settle)))
        elif way == "tilt":
            out.append(Change(rid, tilt_deg=rng.uniform(3, 12), tilt_bearing_deg=rng.uniform(0, 360)))
        elif way == "overturn":
            out.append(Change(rid, orientation="on its side"))
        elif way == "scour":
            # the pit stops short of the nearest neighbour (it would hang that unit in the water)
            size = max(r["length"], r["width"])
            room = min((math.hypot(o["x"] - r["x"], o["y"] - r["y"]) - max(o["length"], o["width"]) / 2
                        for o in reefs if o["id"] != rid), default=10.0)
            radius = min(size / 2 + rng.uniform(1.5, 3), max(room - 0.3, size / 2 + 0.5))
            out.append(Change(rid, scour_depth=rng.uniform(0.3, scour), scour_radius=radius))
        else:
            out.append(Change(rid, status="removed"))
    spot = _free_spot(reefs, rng)
    if spot is not None:
        kind = str(rng.choice(sorted({r["kind"] for r in reefs})))
        out.append(Change(max(r["id"] for r in reefs) + 1, status="new", kind=kind, x=spot[0], y=spot[1],
                          bearing_deg=float(rng.uniform(0, 360))))
    return tuple(out)


def _free_spot(reefs: Sequence[Mapping[str, Any]], rng: np.random.Generator) -> tuple[float, float] | None:
    """A place inside the field at least 6 m from every reef's centre (None: no room)."""
    xy = np.array([[r["x"], r["y"]] for r in reefs])
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    for _ in range(2000):
        p = rng.uniform(lo, hi)
        if np.hypot(*(xy - p).T).min() >= 6.0:
            return float(p[0]), float(p[1])
    return None


def resurvey(truth: Mapping[str, Any], changes: Sequence[Change], *, seed: int,
             shift: tuple[float, float, float] = (0.0, 0.0, 0.0), line_shift: float | None = None,
             progress: Callable[[float], None] | None = None) -> Simulation:
    """The scene of ``truth`` changed as ``changes`` say and surveyed again.

    Parameters
    ----------
    truth : mapping
        A simulation's truth (``truth.json``): its preset, seed and options rebuild the scene.
    changes : sequence of Change
    seed : int
        The new survey's noise (the scene is the truth's).
    shift : (dx, dy, dz)
        Added to every sounding (m): the new survey's position and datum offset.
    line_shift : float, optional
        The lines moved across their track (m); default half the preset's line spacing
        (the lines are also sailed the other way).
    progress : callable, optional

    Returns
    -------
    Simulation
        Its truth holds ``change``: ``registration`` (the true ``dx, dy, dz``) and
        ``objects`` (per reef: ``id``, ``status`` and the true ``dx``, ``dy``,
        ``displacement``, ``rotation_deg``, ``settlement``, ``height_before``,
        ``height_after``, ``tilt_before``, ``tilt_after``, ``overturned_before``,
        ``overturned_after``, ``scour_depth``, ``scour_radius``, ``scour_volume``).
    """
    preset, before_seed = str(truth["preset"]), int(truth["seed"])
    overrides = {**_plain(truth.get("options", {})),
                 **{k: v for k, v in _plain(truth.get("sonar", {})).items() if k != "name"}}
    if "name" in truth.get("sonar", {}):
        overrides["sonar"] = truth["sonar"]["name"]
    setup = _setup(preset, before_seed, overrides)
    ox, oy = setup.scene.origin
    changes = [checked(c) for c in changes]
    piles = bool(setup.scene.piles) and not setup.scene.reefs
    known = set(range(1, len(setup.scene.piles) + 1)) if piles else {r.id for r in setup.scene.reefs}
    bad = [c.id for c in changes if c.status != "new" and c.id not in known]
    if bad:
        what = "pile" if piles else "reef"
        raise ParameterError(f"id: {bad[0]} is no {what} of the scene; expected one of "
                             f"{min(known)}..{max(known)}", option="id")
    if piles:
        for c in changes:
            check_pile_change(c)
    scene = changed_piles(setup.scene, changes) if piles else _changed_scene(setup.scene, changes, setup.opt)
    spacing = float(getattr(setup.opt, "line_spacing", 20.0))
    plan = Survey(_other_lines(setup.plan.lines, spacing / 2 if line_shift is None else line_shift, spacing),
                  setup.sonar)
    cloud, labels, ident = survey(scene, plan, seed=int(np.random.SeedSequence(seed).generate_state(1)[0]),
                                  progress=progress)
    cloud = PointCloud(cloud.xyz + np.asarray(shift, np.float64), dict(cloud.fields), crs=cloud.crs)
    after = scene_truth(preset, before_seed, setup.opt, setup.sonar, scene, labels, {})
    after["sonar"] = {"name": setup.sonar_name, **after["sonar"]}
    after["resurvey_seed"] = seed
    after["change"] = {"registration": {"dx": shift[0], "dy": shift[1], "dz": shift[2]},
                       "objects": (true_pile_changes if piles else _true_changes)(setup.scene, scene, changes,
                                                                                   (ox, oy))}
    return Simulation(cloud, labels, ident, after, scene, plan)


def _plain(d: Mapping[str, Any]) -> dict[str, Any]:
    """JSON values back to what the options hold (lists to tuples)."""
    return {k: tuple(v) if isinstance(v, list) else v for k, v in d.items()}


def _other_lines(lines: Sequence[Line], across: float, spacing: float) -> tuple[Line, ...]:
    """The lines moved ``across`` m to the left of the first line's track, each sailed the
    other way, and one more a line ``spacing`` beyond the first, so that the moved lines
    cover both edges of the old ones."""
    v = np.asarray(lines[0].vertices, np.float64)
    u = (v[-1] - v[0]) / max(float(np.hypot(*(v[-1] - v[0]))), 1e-9)
    n = np.array([-u[1], u[0]])

    def moved(ln: Line, by: float, back: bool) -> Line:
        pts = reversed(ln.vertices) if back else ln.vertices
        return dataclasses.replace(ln, vertices=tuple((float(x + n[0] * by), float(y + n[1] * by))
                                                      for x, y in pts))

    # the lines alternate their heading: the extra line keeps the alternation
    return (moved(lines[0], across - spacing, False),) + tuple(moved(ln, across, True) for ln in lines)


def _changed_scene(scene: Scene, changes: Sequence[Change], opt: Any) -> Scene:
    """The scene with each reef changed, removed or added, and the scour pits dug."""
    by_id = {c.id: c for c in changes}
    ox, oy = scene.origin
    dug = [(r, by_id[r.id]) for r in scene.reefs if r.id in by_id and by_id[r.id].scour_depth > 0]
    pits = tuple((r.x + c.dx, r.y + c.dy, c.scour_depth, c.scour_radius) for r, c in dug)
    seabed = dataclasses.replace(scene.seabed, pits=scene.seabed.pits + pits) if pits else scene.seabed
    scale = float(getattr(opt, "reef_scale", 1.0))
    reefs = []
    for r in scene.reefs:
        c = by_id.get(r.id)
        if c is not None and c.status == "removed":
            continue
        if c is None or (c.dx, c.dy, c.rotation_deg, c.settlement) == (0, 0, 0, 0) and c.orientation is None \
                and c.tilt_deg is None:
            reefs.append(r)
            continue
        sink = float(scene.seabed.elevation(r.x, r.y)) - min(float(b.solid()[0][2]) for b in r.boxes)
        x, y = r.x + c.dx, r.y + c.dy
        way = c.orientation or r.orientation
        tilt = r.tilt_deg if c.tilt_deg is None else c.tilt_deg
        toward = r.tilt_bearing_deg if c.tilt_bearing_deg is None else c.tilt_bearing_deg
        b = (r.bearing_deg + c.rotation_deg) % 360.0
        z = float(scene.seabed.elevation(x, y)) - sink - c.settlement
        boxes = reef_boxes(r.kind, x, y, b, z, scale, way, tilt, toward)
        if way == r.orientation and tilt != r.tilt_deg:
            # a unit leans as one side sinks: its high edge stays where it was
            rise = max(bx.top for bx in boxes) - max(bx.top for bx in r.boxes) + c.settlement
            boxes = reef_boxes(r.kind, x, y, b, z - rise, scale, way, tilt, toward)
        reefs.append(Reef(r.id, r.kind, x, y, b, boxes, group=r.group, material=r.material, orientation=way,
                          tilt_deg=tilt, tilt_bearing_deg=toward))
    for c in changes:
        if c.status == "new":
            x, y = c.x - ox, c.y - oy
            z = float(seabed.elevation(x, y)) - 0.1
            reefs.append(Reef(c.id, c.kind, x, y, c.bearing_deg,
                              reef_boxes(c.kind, x, y, c.bearing_deg, z, scale), group=0))
    return dataclasses.replace(scene, seabed=seabed, reefs=tuple(reefs))


def _true_changes(before: Scene, after: Scene, changes: Sequence[Change], origin: tuple[float, float]
                  ) -> list[dict[str, Any]]:
    """Per reef of either scene, its true change (the before survey's frame)."""
    by_id = {c.id: c for c in changes}
    b = {r.id: r for r in before.reefs}
    a = {r.id: r for r in after.reefs}
    dug = after.seabed.pits[len(before.seabed.pits):]
    after_truth = {rid: reef_truth(r, after.seabed, origin) for rid, r in a.items()}
    feet = {rid: np.asarray(t["outline"]) for rid, t in after_truth.items()} if dug else {}
    out = []
    for rid in sorted(set(b) | set(a)):
        if rid not in a:
            out.append({"id": rid, "status": "removed"})
            continue
        ta = after_truth[rid]
        if rid not in b:
            out.append({"id": rid, "status": "new", "x_after": ta["x"], "y_after": ta["y"],
                        "height_after": exposed_height(ta, after.seabed, origin)})
            continue
        tb = reef_truth(b[rid], before.seabed, origin)
        c = by_id.get(rid, Change(rid))
        dx, dy = ta["x"] - tb["x"], ta["y"] - tb["y"]
        out.append({"id": rid, "status": "changed" if rid in by_id else "unchanged",
                    "x_before": tb["x"], "y_before": tb["y"], "x_after": ta["x"], "y_after": ta["y"],
                    "dx": dx, "dy": dy, "displacement": math.hypot(dx, dy), "rotation_deg": c.rotation_deg,
                    "settlement": tb["z_top"] - ta["z_top"],
                    "height_before": exposed_height(tb, before.seabed, origin),
                    "height_after": exposed_height(ta, after.seabed, origin), "tilt_before": b[rid].tilt_deg,
                    "tilt_after": a[rid].tilt_deg,
                    "overturned_before": b[rid].orientation != "upright",
                    "overturned_after": a[rid].orientation != "upright",
                    **scour_truth(dug, ta, (a[rid].x, a[rid].y), origin,
                                  [f for k, f in feet.items() if k != rid])})
    return out


def scour_truth(pits: Sequence[tuple[float, float, float, float]], reef: Mapping[str, Any],
                centre: tuple[float, float], origin: tuple[float, float],
                others: Sequence[np.ndarray] = ()) -> dict[str, float]:
    """The scour the scene's ``pits`` (local coordinates, as the seabed holds them) leave
    round a reef centred at local ``centre``, outside its footprint (``reef``: its truth
    record, in the survey's coordinates) and the ``others``' footprints, each grown by
    :data:`mbinspect.scour.FOOT_MARGIN`, read as :func:`mbinspect.scour.pit_scour` reads
    them: depth, radius and volume (m³)."""
    from ..scour import pit_scour

    ox, oy = origin
    return pit_scour([(x + ox, y + oy, d, r) for x, y, d, r in pits], np.asarray(reef["outline"]),
                     (centre[0] + ox, centre[1] + oy), others=others)


def random_pile_changes(truth: Mapping[str, Any], *, seed: int, share: float = 0.5) -> tuple[Change, ...]:
    """Changes for a study: about ``share`` of the piles changed, each one way drawn at
    random (settled 2 to 10 cm, leaning 1 to 4° more, or scoured 0.3 to 1.0 m deep within
    3 to 5 m), the rest left alone."""
    rng = np.random.default_rng(seed)
    out = []
    for p in truth["piles"]:
        if rng.random() >= share:
            continue
        way = rng.choice(["settle", "tilt", "scour"])
        pid = int(p["id"])
        if way == "settle":
            out.append(Change(pid, settlement=float(rng.uniform(0.02, 0.10))))
        elif way == "tilt":
            out.append(Change(pid, tilt_deg=float(p["tilt_deg"]) + float(rng.uniform(1, 4)),
                              tilt_bearing_deg=float(rng.uniform(0, 360))))
        else:
            out.append(Change(pid, scour_depth=float(rng.uniform(0.3, 1.0)),
                              scour_radius=float(rng.uniform(3, 5))))
    return tuple(out)
