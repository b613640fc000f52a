"""Piles and reefs injected into the real files of ``../shared/real``: what their lines can measure.

Run: ``python benchmarks/study_inject.py [--placements 5] [--objects piles,reefs] [--prior-offset M]
[--only NAME] [--beam DEG [--detection auto] [--untold]]``. ``--beam`` injects through cones of
that width (issue 28), the objects then carry the beam's smear as well as the real noise, and
``locate_piles`` is told the beam (``beam_width_deg``) unless ``--untold``.
For each real file with at least 8 m of seabed both ways (5th to 95th percentile) and under 60 m deep, a
jacket of four piles (radius 0.5 m, sides 6 m or half the seabed's width, tops 2 m above the seabed) is
injected at seeded placements (shift within 1.5 m of the centre, any turn) with
``mbinspect.inject``: each sounding whose beam meets a pile is moved onto it along its own
beam, carrying its own seabed residual. ``locate_piles`` (count 4, radius 0.5) then measures
them (``--prior-offset`` gives it a radius prior that far off). A file whose pings cover a strip
at least 1.5 m wide and 5 m long at least 20 times (``ets_kmall_eg``: 25 pings over 2.2 m) gets
a row of two piles 1.2 m proud along the strip instead (0.6 of its length apart, at most 6 m). Per file:
pings, soundings per pile, piles found and flagged, spacing error RMS and max over the
spacings of unflagged piles and over all, the shares within the reported 2σ and 3σ, runs
stopped and placements over holes. The public files are short (4–67 pings), so few
soundings reach a pile: the figure that matters is whether what cannot be measured is flagged.
A file recorded with the vessel holding station (``ets_all_a_y``: 35 pings of an EM2045 within
0.1 m, 11 m deep) has its pings laid 0.15 m apart along a line (``STATION_STEP``; each keeps
its own beams, ranges, noise and backscatter; the seabed is then its one profile repeated) and
gets the row of two piles.

Reefs: four built-in designs (cross1, cross2, hollow and triangle, the last two at 0.7 of
their size, sunk 0.1 m) on a square of 6 m sides (or half the seabed's width, at least
4.5 m; on a smaller file a cross1 and a hollow 5.5 m apart) at seeded placements;
``extract_reefs`` with the reference (the injected centres) and the designs (their scale
tolerance 0.35, for the two built at 0.7) scores them:
reefs found, false reefs, objects set aside, and the exposed height error of the matches.
"""

from __future__ import annotations

import argparse
import math
import re
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _common import real_clouds, table  # noqa: E402
from mbinspect.beam import Beam  # noqa: E402
from mbinspect.errors import MBInspectError  # noqa: E402
from mbinspect.inject import InjectedPile, InjectedReef, inject  # noqa: E402
from mbinspect.io import PointCloud  # noqa: E402
from mbinspect.piles import locate_piles  # noqa: E402
from mbinspect.reefs import extract_reefs  # noqa: E402
from mbinspect.simulate.scene import MATERIAL_BS  # noqa: E402

SIDE, RADIUS, HEIGHT = 6.0, 0.5, 2.0  # side: at most
#: an injected pile's echo over the seabed's (dB): the simulator's concrete over its sediment
CONTRAST_DB = MATERIAL_BS["concrete"] - MATERIAL_BS["sediment"]
#: A row's piles stand 1.2 m proud: in 3.5 m of water a 50° swath sees the top of a 2 m pile
#: only in a sliver (its beams meet the side first), as a real sonar would.
ROW_HEIGHT = 1.6


def _row(cloud: PointCloud, rng: np.random.Generator) -> tuple[list[InjectedPile], float]:
    """Two piles along a narrow strip's long axis (a pair of a jacket's piles), shifted by up
    to 0.3 m either way, and their spacing: for a file whose pings cover a strip too narrow
    for a square but dense along it."""
    xy = cloud.xyz[:, :2]
    centre = np.median(xy, axis=0)
    _, vec = np.linalg.eigh(np.cov((xy - centre).T))
    u, v = vec[:, 1], vec[:, 0]  # long and short axes
    lo, hi = np.percentile((xy - centre) @ u, [5, 95])
    spacing = min(SIDE, 0.6 * float(hi - lo))
    mid = centre + (lo + hi) / 2 * u + rng.uniform(-0.3, 0.3) * u + rng.uniform(-0.3, 0.3) * v
    return [InjectedPile(i + 1, *(mid + sgn * spacing / 2 * u), RADIUS, height=ROW_HEIGHT)
            for i, sgn in enumerate((-1.0, 1.0))], spacing


def _layout(cloud: PointCloud) -> str | None:
    """"square" where the seabed spans 8 m both ways, "row" where a strip at least 1.5 m wide
    and 5 m long is pinged at least 20 times, else None (5th to 95th percentile, under 60 m)."""
    if -np.median(cloud.xyz[:, 2]) >= 60:
        return None
    xy = cloud.xyz[:, :2] - np.median(cloud.xyz[:, :2], axis=0)
    lo, hi = np.percentile(xy, [5, 95], axis=0)
    if (hi - lo).min() >= 8.0:
        return "square"
    _, vec = np.linalg.eigh(np.cov(xy.T))
    ext = np.ptp(np.percentile(xy @ vec, [5, 95], axis=0), axis=0)
    if ext.min() >= 1.5 and ext.max() >= 5.0 and len(np.unique(cloud.fields["ping"])) >= 20:
        return "row"
    return None


def _jacket(cx: float, cy: float, side: float, rng: np.random.Generator) -> list[InjectedPile]:
    turn = rng.uniform(0, 2 * math.pi)
    sx, sy = rng.uniform(-1.5, 1.5, 2)
    corners = [(-1, -1), (1, -1), (1, 1), (-1, 1)]
    c, s = math.cos(turn), math.sin(turn)
    return [InjectedPile(i + 1, cx + sx + side / 2 * (c * u - s * v), cy + sy + side / 2 * (s * u + c * v),
                         RADIUS, height=HEIGHT) for i, (u, v) in enumerate(corners)]


#: the reefs of a placement: kind and scale, one per corner of the square
REEFS = (("cross1", 1.0), ("cross2", 1.0), ("hollow", 0.7), ("triangle", 0.7))


def _reef_square(cx: float, cy: float, side: float, rng: np.random.Generator) -> list[InjectedReef]:
    """The four reefs on a square's corners, or on a small file two of them 5.5 m apart."""
    turn = rng.uniform(0, 2 * math.pi)
    sx, sy = rng.uniform(-1.0, 1.0, 2)
    if side >= 4.5:
        corners, kinds = [(-side / 2, -side / 2), (side / 2, -side / 2), (side / 2, side / 2),
                          (-side / 2, side / 2)], REEFS
    else:
        corners, kinds = [(-2.75, 0.0), (2.75, 0.0)], (REEFS[0], REEFS[2])
    c, s = math.cos(turn), math.sin(turn)
    return [InjectedReef(i + 1, cx + sx + c * u - s * v, cy + sy + s * u + c * v,
                         kind, bearing_deg=float(rng.uniform(0, 360)), scale=scale)
            for i, ((u, v), (kind, scale)) in enumerate(zip(corners, kinds, strict=True))]


def site(cloud: PointCloud, largest: float = 6.0) -> tuple[float, float, float]:
    """Where a square of objects goes in a file: the soundings' median position and the
    square's side, at most ``largest`` m and half the narrower of the 5-95 % extents."""
    cx, cy = np.median(cloud.xyz[:, :2], axis=0)
    lo, hi = np.percentile(cloud.xyz[:, :2], [5, 95], axis=0)
    return float(cx), float(cy), min(largest, float((hi - lo).min()) / 2)


def _reef_row(name: str, cloud: PointCloud, side: float, placements: int, beam: Beam | None,
              told: dict | None = None) -> list[str]:
    """Inject the four reefs at each placement and score ``extract_reefs`` (with designs; told
    the beam with ``told``: ``beam_correction`` and its options)."""
    cx, cy = np.median(cloud.xyz[:, :2], axis=0)
    hits, tp, fp, fn, others, dh, da, unplaced, stopped = [], 0, 0, 0, 0, [], [], 0, 0
    for k in range(placements):
        try:
            inj = inject(cloud.xyz, cloud.fields, reefs=_reef_square(cx, cy, side, np.random.default_rng(k)),
                         beam=beam)
        except MBInspectError:
            unplaced += 1
            continue
        hits += list(inj.truth["counts"]["per_reef"].values())
        truth = inj.truth["reefs"]
        ref = (np.array([[r["x"], r["y"]] for r in truth]), tuple(r["id"] for r in truth))
        try:
            # two designs are built at 0.7 of their size here: a tolerance that admits them
            res = extract_reefs(PointCloud(inj.xyz, dict(cloud.fields)), reference=ref,
                                design=",".join(k for k, _ in REEFS), design_scale_tolerance=0.35,
                                **(told or {}))
        except MBInspectError:
            stopped += 1
            fn += len(truth)
            continue
        ev = res.evaluation
        tp, fp, fn, others = tp + ev.tp, fp + ev.fp, fn + ev.fn, others + len(res.others)
        dh += [res.reefs[i].height - truth[j]["height"] for i, j, _ in ev.matches]
        da += [res.reefs[i].area / truth[j]["area"] - 1 for i, j, _ in ev.matches]
    per = f"{int(np.median(hits))}" if hits else "-"
    return [name[:30], f"{-np.median(cloud.xyz[:, 2]):.0f}", f"{side:.1f}", per, f"{tp}/{tp + fn}", f"{fp}",
            f"{others}", f"{100 * np.median(np.abs(dh)):.1f}" if dh else "-",
            f"{100 * np.max(np.abs(dh)):.1f}" if dh else "-", f"{100 * np.mean(da):+.1f} %" if da else "-",
            f"{stopped}", f"{unplaced}"]


#: Along-track step (m) between the pings of a file recorded with the vessel holding station
#: (``ets_all_a_y``: 35 pings within 0.1 m), laid out as a line sailed at about 1.5 m/s and
#: 10 pings a second; each ping keeps its own beams, ranges, noise and backscatter.
STATION_STEP = 0.15


def _spread(cloud: PointCloud) -> PointCloud | None:
    """The pings of a file recorded holding station laid one :data:`STATION_STEP` apart
    across their swath, in ping order; None for a file whose pings already move (or fewer
    than 20 pings)."""
    ping = cloud.fields.get("ping")
    if ping is None or len(np.unique(ping)) < 20:
        return None
    xy = cloud.xyz[:, :2] - np.median(cloud.xyz[:, :2], axis=0)
    _, vec = np.linalg.eigh(np.cov(xy.T))
    along = vec[:, 0]  # square to the swath
    if np.ptp(np.percentile(xy @ along, [5, 95])) >= 0.5:
        return None
    _, k = np.unique(ping, return_inverse=True)
    xyz = cloud.xyz.copy()
    xyz[:, :2] += (k.ravel() * STATION_STEP)[:, None] * along[None, :]
    return PointCloud(xyz, dict(cloud.fields))


def _files(only: str = "") -> list[tuple[str, PointCloud, str]]:
    """The real files the objects can go into (those whose name holds ``only``), with the
    layout of their piles; a file recorded holding station with its pings spread along a
    line (:func:`_spread`)."""
    out = []
    for name, cloud in real_clouds():
        if only not in name:
            continue
        layout = _layout(cloud)
        if layout is None and (moved := _spread(cloud)) is not None and (layout := _layout(moved)):
            name, cloud = f"{name[:22]} (pings spread)", moved
        if layout is not None:
            out.append((name, cloud, layout))
    return out


def compared(tally: Any, step: Callable[[], tuple]) -> tuple | None:
    """``step()``'s result (its last item a comparison), or None with the reason counted in
    ``tally``: the library stopped with an error, or the comparison's registration found no
    seabed to stand on."""
    try:
        out = step()
    except MBInspectError as exc:
        tally["stopped: " + re.sub(r"\([0-9., ]+\)", "(…)", str(exc))[:60]] += 1
        return None
    g = out[-1].registration
    if not math.isfinite(g.sigma_dz):
        tally["not registered: " + g.note[:50]] += 1
        return None
    return out


def paired_halves(only: str = ""
                  ) -> list[tuple[str, PointCloud, tuple[float, float, float], list[PointCloud]]]:
    """Each real file that holds a square of objects and records its pings, as two surveys of
    one place: its even and its odd pings (the real seabed, each half's noise its own), with
    the file and where the square goes (:func:`site`)."""
    out = []
    for name, cloud, layout in _files(only):
        if layout != "square" or "ping" not in cloud.fields:
            continue
        even = (np.asarray(cloud.fields["ping"]) % 2) == 0
        halves = [PointCloud(cloud.xyz[m], {k: np.asarray(v)[m] for k, v in cloud.fields.items()},
                             crs=cloud.crs) for m in (even, ~even)]
        out.append((name, cloud, site(cloud), halves))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--placements", type=int, default=5)
    ap.add_argument("--objects", default="piles,reefs", help="piles, reefs or both")
    ap.add_argument("--prior-offset", type=float, default=0.0,
                    help="the radius prior given to locate_piles minus the injected radius (m)")
    ap.add_argument("--only", default="", help="only the real files whose name holds this")
    ap.add_argument("--beam", type=float, default=0.0,
                    help="inject through beams this wide (deg, across and along; 0: thin rays)")
    ap.add_argument("--detection", default="auto", help="the beam's bottom detection (with --beam)")
    ap.add_argument("--untold", action="store_true",
                    help="with --beam: locate_piles is not told the beam (beam_width_deg 0)")
    args = ap.parse_args()
    beam = Beam(beam_across_deg=args.beam, detection=args.detection) if args.beam > 0 else None
    # the injection gives a pile's echo the simulator's concrete over its sediment (18 dB) but
    # leaves the soundings' intensities as they were: the correction is told that contrast
    told = ({"beam_width_deg": args.beam, "detection": args.detection, "beam_contrast_db": CONTRAST_DB}
            if beam and not args.untold else {})
    print(f"beam: {args.beam:g} deg, {args.detection} detection; locate_piles "
          f"{'told it' if told else 'not told it'}" if beam else "beam: thin rays")
    files = _files(args.only)
    if "reefs" in args.objects:
        reef_rows = []
        for name, cloud, layout in files:
            if layout != "square":
                continue
            reef_told = ({"beam_correction": True, "beam_width_deg": args.beam, "detection": args.detection,
                          "beam_contrast_db": CONTRAST_DB} if beam and not args.untold else None)
            reef_rows.append(_reef_row(name, cloud, site(cloud)[2], args.placements, beam, reef_told))
        print(table(["file", "depth m", "side m", "soundings per reef (median)", "reefs found", "false reefs",
                     "others", "height err median cm", "height err max cm", "area err mean", "runs stopped",
                     "not placed"],
                    reef_rows))
        print()
    if "piles" not in args.objects:
        return
    rows, reasons = [], set()
    for name, cloud, layout in files:
        cx, cy, side = site(cloud, SIDE)
        hits, found, flagged, aborted, unplaced = [], 0, 0, 0, 0
        err_ok, err_all, err_seen, within, within3 = [], [], [], [], []
        for k in range(args.placements):
            if layout == "row":
                piles, side = _row(cloud, np.random.default_rng(k))
            else:
                piles = _jacket(cx, cy, side, np.random.default_rng(k))
            try:
                inj = inject(cloud.xyz, cloud.fields, piles=piles, beam=beam)
            except MBInspectError:  # a pile over a hole in the coverage
                unplaced += 1
                continue
            hits += list(inj.truth["counts"]["per_pile"].values())
            truth = {p["id"]: p for p in inj.truth["piles"]}
            try:
                res = locate_piles(PointCloud(inj.xyz, dict(cloud.fields)), count=len(piles),
                                   radius=RADIUS + args.prior_offset, seed=k, **told)
            except MBInspectError as exc:
                aborted += 1
                reasons.add(str(exc).split(": ", 1)[-1][:70])
                continue
            near = {p.id: min(truth, key=lambda i, p=p: math.hypot(p.x - truth[i]["x"], p.y - truth[i]["y"]))
                    for p in res.piles}
            found += len(set(near.values()))
            flagged += sum(bool(p.flags) for p in res.piles)
            bad = {p.id for p in res.piles if p.flags}
            # the condition for a 3 cm answer: 90 deg of side arc or a covered top
            seen = {p.id for p in res.piles if p.side_coverage_deg >= 90 or (p.top_coverage or 0) >= 0.8}
            for sp in res.spacings:
                ta, tb = truth[near[sp.a]], truth[near[sp.b]]
                e = sp.distance - math.hypot(ta["x"] - tb["x"], ta["y"] - tb["y"])
                err_all.append(e)
                within.append(abs(e) <= 2 * sp.sigma)
                within3.append(abs(e) <= 3 * sp.sigma)
                if sp.a not in bad and sp.b not in bad:
                    err_ok.append(e)
                if sp.a in seen and sp.b in seen:
                    err_seen.append(e)

        def rms(v: list[float]) -> str:
            return f"{100 * math.sqrt(np.mean(np.square(v))):.1f}" if v else "-"

        def mx(v: list[float]) -> str:
            return f"{100 * np.max(np.abs(v)):.1f}" if v else "-"

        n = len(piles) * (args.placements - unplaced)
        per_pile = f"{int(np.median(hits))}" if hits else "-"
        pings = len(np.unique(cloud.fields["ping"]))
        rows.append([name[:38] + (" (row of 2)" if layout == "row" else ""),
                     f"{-np.median(cloud.xyz[:, 2]):.0f}", f"{pings}", f"{side:.1f}", per_pile,
                     f"{found}/{n}", f"{flagged}", f"{len(err_ok)}", rms(err_ok), mx(err_ok),
                     f"{len(err_all)}", rms(err_all), mx(err_all), f"{len(err_seen)}", mx(err_seen),
                     f"{100 * np.mean(within):.0f} %" if within else "-",
                     f"{100 * np.mean(within3):.0f} %" if within3 else "-", f"{aborted}", f"{unplaced}"])
    print(table(["file", "depth m", "pings", "side m", "soundings per pile (median)", "piles found",
                 "piles flagged",
                 "spacings (unflagged)", "RMS cm", "max cm", "spacings (all)", "RMS cm", "max cm",
                 "spacings (both piles: arc >= 90 deg or top covered)", "max cm",
                 "within 2 sigma (all)", "within 3 sigma (all)", "aborted", "not placed"], rows))
    print("\nwhy runs stopped: " + "; ".join(sorted(reasons)))


if __name__ == "__main__":
    main()
