"""The ``mbinspect`` command line: a thin layer over the library.

Each subcommand parses its options, calls one library function and writes that
function's result. A user's mistake is printed as one line on stderr with a non-zero
exit status, never as a traceback.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, NoReturn

from . import __version__
from .errors import MBInspectError, ParameterError

__all__ = ["main"]

EXIT_USER = 2
EXIT_FLAGGED = 3  # results written, but a pile is flagged or a spacing fails the design
EXIT_INTERRUPT = 130


class _UsageError(MBInspectError):
    pass


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors (raised, so ``main`` prints them like any other)."""

    def error(self, message: str) -> NoReturn:
        raise _UsageError(f"{self.prog}: {message} (see '{self.prog} --help')")


class Reporter:
    """Progress and messages on stderr, silenced by ``-q``, detailed by ``-v``."""

    def __init__(self, verbosity: int = 0, stream: Any = None) -> None:
        self.verbosity = verbosity
        self.stream = stream if stream is not None else sys.stderr
        self._t0 = time.perf_counter()
        self._last = -1.0

    def info(self, message: str) -> None:
        if self.verbosity >= 0:
            print(message, file=self.stream, flush=True)

    def debug(self, message: str) -> None:
        if self.verbosity > 0:
            print(f"[{time.perf_counter() - self._t0:7.2f} s] {message}", file=self.stream,
                  flush=True)

    def progress(self, label: str) -> Callable[[float], None]:
        """A callback that shows ``label NN %`` for work of more than a second or two."""
        start = time.perf_counter()
        self._last = -1.0
        tty = hasattr(self.stream, "isatty") and self.stream.isatty()

        def update(fraction: float) -> None:
            if self.verbosity < 0 or time.perf_counter() - start < 1.5 and fraction < 1:
                return
            pct = int(100 * fraction)
            step = 1 if tty else 25
            if pct // step == self._last // step and fraction < 1:
                return
            self._last = pct
            end = "\r" if tty and fraction < 1 else "\n"
            print(f"{label}: {pct:3d} %", end=end, file=self.stream, flush=True)

        return update


# ----------------------------------------------------------------------------- input options


def _add_input(p: argparse.ArgumentParser) -> None:
    p.add_argument("input", help="point cloud file (.xyz .txt .csv .las .laz .ply .npz)")
    g = p.add_argument_group("reading")
    g.add_argument("--format", choices=["xyz", "las", "ply", "npz"],
                   help="file format when the extension does not say it")
    g.add_argument("--columns", metavar="MAP",
                   help="ASCII columns, e.g. x,y,z,intensity or x,y,-,z ('-' skips)")
    g.add_argument("--delimiter", metavar="D",
                   help="ASCII delimiter: ',' ';' tab or space (default: sniffed)")
    g.add_argument("--depth-positive", action="store_true",
                   help="z in the file is depth, positive down (it is negated)")


def _read_input(args: argparse.Namespace, rep: Reporter) -> Any:
    from .io import read

    t = time.perf_counter()
    cloud = read(args.input, format=args.format, columns=args.columns,
                 depth_positive=args.depth_positive, delimiter=args.delimiter)
    rep.debug(f"read {len(cloud):,} points from {args.input} in {time.perf_counter() - t:.2f} s")
    return cloud


# ----------------------------------------------------------------------------- info


def _cmd_info(args: argparse.Namespace, rep: Reporter) -> int:
    from .io import describe

    summary = describe(_read_input(args, rep), cell=args.cell)
    d = summary.to_dict()
    if args.json:
        print(json.dumps(d, indent=2))
        return 0
    lo, hi = summary.bounds_min, summary.bounds_max
    lines = [
        f"file        {summary.source}",
        f"points      {summary.n_points:,}",
        f"x range     {lo[0]:.3f} .. {hi[0]:.3f}  ({hi[0] - lo[0]:.2f} m)",
        f"y range     {lo[1]:.3f} .. {hi[1]:.3f}  ({hi[1] - lo[1]:.2f} m)",
        f"z range     {lo[2]:.3f} .. {hi[2]:.3f}  ({hi[2] - lo[2]:.2f} m, elevation, up)",
        f"fields      {', '.join(summary.fields) or '(none)'}",
        f"area        {summary.area:,.0f} m^2 covered ({summary.cell:g} m cells)",
        f"density     {summary.density:.1f} pts/m^2",
        f"spacing     {summary.spacing:.3f} m (median nearest neighbour, plan)",
    ]
    if summary.crs:
        lines.append(f"crs         {summary.crs[:70]}")
    print("\n".join(lines))
    return 0


# ----------------------------------------------------------------------------- simulate


def _add_simulate_options(p: argparse.ArgumentParser) -> None:
    from .simulate import PRESETS, option_fields

    seen: set[str] = set()
    for preset in PRESETS:
        g = p.add_argument_group(f"{preset} options (defaults in 'mbinspect simulate "
                                 f"{preset} --show-options')")
        for f in option_fields(preset):
            if f.name in seen:
                continue
            seen.add(f.name)
            flag = "--" + f.name.replace("_", "-")
            kind = type(f.default)
            if kind is bool:
                g.add_argument(flag, dest=f"opt_{f.name}", type=_parse_bool, metavar="BOOL")
            else:
                g.add_argument(flag, dest=f"opt_{f.name}", type=kind, metavar=kind.__name__.upper())


def _parse_bool(text: str) -> bool:
    if text.lower() in ("1", "true", "yes", "on"):
        return True
    if text.lower() in ("0", "false", "no", "off"):
        return False
    raise argparse.ArgumentTypeError(f"{text!r} is not true or false")


def _cmd_simulate(args: argparse.Namespace, rep: Reporter) -> int:
    from .io import output_dir, write, write_json, write_table
    from .simulate import option_fields, simulate

    names = {f.name for f in option_fields(args.preset)}
    given = {k[4:]: v for k, v in vars(args).items() if k.startswith("opt_") and v is not None}
    foreign = sorted(set(given) - names)
    if foreign:
        raise ParameterError(
            f"--{foreign[0].replace('_', '-')}: not an option of the {args.preset} preset"
        )
    if args.show_options:
        from .simulate import PRESETS

        opt_cls, sonar = PRESETS[args.preset]
        values = {**dataclasses.asdict(opt_cls()), **dataclasses.asdict(sonar)}
        for f in option_fields(args.preset):
            print(f"--{f.name.replace('_', '-'):24s} {values[f.name]}")
        return 0
    out = Path(args.out) if args.out else Path(f"sim-{args.preset}-{args.seed}")
    ext = {"xyz": ".xyz", "las": ".las", "laz": ".laz", "ply": ".ply", "npz": ".npz"}[args.format]
    with output_dir(out, overwrite=args.overwrite) as tmp:
        t = time.perf_counter()
        sim = simulate(args.preset, seed=args.seed, progress=rep.progress("ray casting"), **given)
        rep.debug(f"simulated {len(sim.cloud):,} soundings in {time.perf_counter() - t:.2f} s")
        cloud_path = tmp / f"soundings{ext}"
        write(sim.cloud, cloud_path)
        write_json(sim.truth, tmp / "truth.json")
        import numpy as np

        np.savez_compressed(tmp / "labels.npz", label=sim.labels, ident=sim.ident)
        if sim.truth.get("design"):
            write_table(sim.truth["design"], tmp / "design.csv", ["id", "x", "y"])
        if sim.truth["reefs"]:
            rows = [{"x": x, "y": y, "id": i} for x, y, i in sim.reference_rows(seed=args.seed)]
            write_table(rows, tmp / "reference.csv", ["x", "y", "id"])
    n_obj = (f"{len(sim.truth['piles'])} piles" if sim.truth["piles"]
             else f"{len(sim.truth['reefs'])} reefs")
    rep.info(f"{args.preset}: {len(sim.cloud):,} soundings, {n_obj}, written to "
             f"{out / cloud_path.name} with truth.json")
    return 0


# ----------------------------------------------------------------------------- piles


def _floats(text: str) -> tuple[float, ...]:
    try:
        return tuple(float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a comma-separated list of numbers") from None


def _add_pile_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("piles")
    g.add_argument("--count", type=int, metavar="K",
                   help="number of piles (K-means); found from the data if omitted")
    g.add_argument("--radius", type=float, metavar="R", help="prior pile radius (m)")
    g.add_argument("--method", choices=["intersection", "centre", "both"], default="intersection",
                   help="top-centre method (default intersection)")
    g.add_argument("--design", metavar="CSV", help="design positions (id,x,y) or spacings (a,b,distance)")
    g.add_argument("--tolerance", type=float, default=0.05, metavar="M",
                   help="pass/fail tolerance on spacing deviations (default 0.05 m)")
    g.add_argument("--crop", type=_floats, metavar="XMIN,YMIN,XMAX,YMAX", help="keep only this box")
    t = p.add_argument_group("thresholds (defaults follow the paper)")
    t.add_argument("--min-height", type=float, default=1.0, metavar="M",
                   help="pile points stand this far above the local seabed (default 1.0)")
    t.add_argument("--window", type=float, default=0.1, metavar="M", help="top elevation window (0.1)")
    t.add_argument("--step", type=float, default=0.01, metavar="M", help="window step (0.01)")
    t.add_argument("--ks", type=float, default=0.1, metavar="M", help="centre method k_s (0.1)")
    t.add_argument("--threshold", type=float, default=0.06, metavar="M",
                   help="inlier distance of the cylinder and plane fits (0.06)")
    t.add_argument("--delta", type=float, default=0.01, metavar="M",
                   help="stop when every spacing changes by less than this (0.01)")
    t.add_argument("--max-iterations", type=int, default=20, metavar="N")
    t.add_argument("--segmentation", choices=["joint", "paper"], default="joint",
                   help="window + normals + backscatter (joint) or the window alone (paper)")
    t.add_argument("--no-intensity", action="store_true", help="do not use backscatter")
    t.add_argument("--radius-mode", choices=["auto", "fixed", "free"], default="auto",
                   help="keep the prior radius (fixed, the paper), fit it (free), or fit it where "
                        "the side coverage supports it (auto, default)")
    t.add_argument("--max-sigma", type=float, default=0.005, metavar="M",
                   help="flag a pile whose plan 1-sigma exceeds this (default 0.005 m)")
    t.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    o = p.add_argument_group("output")
    o.add_argument("--out", metavar="DIR", help="output folder (default piles-out)")
    o.add_argument("--overwrite", action="store_true", help="replace an existing --out folder")
    o.add_argument("--no-figures", action="store_true", help="tables and JSON only")


def _pile_kwargs(args: argparse.Namespace) -> dict[str, Any]:
    from .piles import read_design

    if args.radius is None:
        raise ParameterError("--radius: required (the prior pile radius in metres)")
    return dict(
        radius=args.radius, count=args.count, method=args.method, tolerance=args.tolerance,
        design=read_design(args.design) if args.design else None,
        crop=args.crop, min_height=args.min_height, window=args.window, step=args.step,
        ks=args.ks, threshold=args.threshold, delta=args.delta,
        max_iterations=args.max_iterations, segmentation=args.segmentation,
        radius_mode=args.radius_mode, max_sigma=args.max_sigma,
        use_intensity=not args.no_intensity, seed=args.seed,
    )


def _finish_piles(result: Any, cloud: Any, out: Path, args: argparse.Namespace, rep: Reporter,
                  inputs: Sequence[str], truth: Any = None,
                  title: str = "Pile positions and spacings") -> int:
    from .io import output_dir
    from .report import spacing_table, write_pile_outputs

    with output_dir(out, overwrite=args.overwrite, inputs=inputs) as tmp:
        write_pile_outputs(result, cloud.xyz, tmp, figures=not args.no_figures, truth=truth,
                           title=title)
    tp = None if truth is None else {(s["a"], s["b"]): s["distance"] for s in truth["spacings"]}
    if rep.verbosity >= 0:
        print(spacing_table(result, tp))
    for w in result.warnings:
        print(f"mbinspect: warning: {w}", file=sys.stderr)
    for p in result.piles:
        for f in p.flags:
            print(f"mbinspect: warning: pile {p.id}: {f}", file=sys.stderr)
    rep.info(f"results in {out}/ (report.html, piles.json, piles.csv, spacings.csv)")
    failed = any(s.passed is False for s in result.spacings)
    return EXIT_FLAGGED if (failed or not result.ok) else 0


def _cmd_piles(args: argparse.Namespace, rep: Reporter) -> int:
    from .piles import locate_piles

    kwargs = _pile_kwargs(args)
    cloud = _read_input(args, rep)
    t = time.perf_counter()
    result = locate_piles(cloud, progress=rep.progress("piles"), **kwargs)
    rep.debug(f"located {len(result.piles)} piles in {time.perf_counter() - t:.2f} s")
    return _finish_piles(result, cloud, Path(args.out or "piles-out"), args, rep, [args.input])


def _cmd_demo(args: argparse.Namespace, rep: Reporter) -> int:
    from .piles import Design, locate_piles
    from .simulate import simulate

    t = time.perf_counter()
    sim = simulate("jacket", seed=args.seed, progress=rep.progress("simulating the jacket survey"))
    rep.info(f"simulated the jacket preset: {len(sim.cloud):,} soundings in "
             f"{time.perf_counter() - t:.1f} s (seed {args.seed})")
    design = Design(positions={d["id"]: (d["x"], d["y"]) for d in sim.truth["design"]},
                    source="design of the simulated jacket")
    t = time.perf_counter()
    result = locate_piles(sim.cloud, count=4, radius=sim.truth["piles"][0]["radius"],
                          method=args.method, design=design, seed=args.seed,
                          progress=rep.progress("piles"))
    rep.info(f"located {len(result.piles)} piles in {time.perf_counter() - t:.1f} s; spacings "
             "against the design (22 m sides) and the simulator's truth:")
    out = Path(args.out or "demo-out")
    code = _finish_piles(result, sim.cloud, out, args, rep, [], truth=sim.truth,
                         title="mbinspect demo: a simulated four-pile jacket")
    from .io import write_json

    write_json(sim.truth, out / "truth.json")
    return code


# ----------------------------------------------------------------------------- reefs


def _add_reef_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("reefs")
    g.add_argument("--reference", metavar="CSV", help="reference reef positions: x,y[,id]")
    g.add_argument("--tolerance", type=float, default=1.5, metavar="M",
                   help="matching distance to the reference (default 1.5 m)")
    g.add_argument("--method", choices=["local", "paper"], default="local",
                   help="ours (local) or the paper's plain method (radius filter, one plane, clusters)")
    g.add_argument("--crop", type=_floats, metavar="XMIN,YMIN,XMAX,YMAX", help="keep only this box")
    t = p.add_argument_group("thresholds (defaults follow the paper where it gives them)")
    t.add_argument("--no-exclude-rough", action="store_true", help="keep steep, rough terrain")
    t.add_argument("--max-slope", type=float, default=15.0, metavar="DEG", help="steep terrain (15)")
    t.add_argument("--max-roughness", type=float, default=0.2, metavar="M", help="rough terrain RMS (0.2)")
    t.add_argument("--noise-radius", type=float, default=0.5, metavar="M", help="radius filter r (0.5)")
    t.add_argument("--noise-neighbors", type=int, default=3, metavar="N",
                   help="radius filter: noise if <= N neighbours (3)")
    t.add_argument("--seabed", choices=["auto", "plane", "grid"], default="auto",
                   help="RANSAC plane, local grid, or the plane when it fits (auto)")
    t.add_argument("--plane-threshold", type=float, default=0.5, metavar="M", help="RANSAC D (0.5)")
    t.add_argument("--min-height", type=float, default=0.3, metavar="M", help="reef core height (0.3)")
    t.add_argument("--foot-height", type=float, default=0.15, metavar="M", help="reef foot height (0.15)")
    t.add_argument("--reef-area", type=float, metavar="M2", help="single-reef footprint (default: learnt)")
    t.add_argument("--design", metavar="NAMES",
                   help="the reef designs deployed, comma-separated: built-in names (cross2, cross1, "
                        "hollow, triangle) or JSON design files; each reef is then fitted by its "
                        "design (centre, area, outline, as-built size factor)")
    t.add_argument("--min-area", type=float, default=1.0, metavar="M2",
                   help="smaller objects are not reefs (1.0)")
    t.add_argument("--group-link", type=float, default=12.0, metavar="M", help="group linking distance (12)")
    t.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    o = p.add_argument_group("output")
    o.add_argument("--out", metavar="DIR", help="output folder (default reefs-out)")
    o.add_argument("--overwrite", action="store_true", help="replace an existing --out folder")
    o.add_argument("--no-figures", action="store_true", help="tables and JSON only")


def _cmd_reefs(args: argparse.Namespace, rep: Reporter) -> int:
    from .designs import parse_designs
    from .evaluate import read_reference
    from .io import output_dir
    from .reefs import extract_reefs
    from .report import write_reef_outputs

    designs = parse_designs(args.design)  # a bad name or design file fails before the read
    reference = read_reference(args.reference) if args.reference else None
    cloud = _read_input(args, rep)
    t = time.perf_counter()
    result = extract_reefs(
        cloud, method=args.method, reference=reference, tolerance=args.tolerance, crop=args.crop,
        exclude_rough=not args.no_exclude_rough, max_slope_deg=args.max_slope,
        max_roughness=args.max_roughness, noise_radius=args.noise_radius,
        noise_neighbors=args.noise_neighbors, seabed=args.seabed,
        plane_threshold=args.plane_threshold, min_height=args.min_height,
        foot_height=args.foot_height, reef_area=args.reef_area, design=designs or None,
        min_area=args.min_area, group_link=args.group_link, seed=args.seed, progress=rep.progress("reefs"))
    rep.debug(f"extracted {len(result.reefs)} reefs in {time.perf_counter() - t:.2f} s")
    out = Path(args.out or "reefs-out")
    with output_dir(out, overwrite=args.overwrite, inputs=[args.input]) as tmp:
        write_reef_outputs(result, cloud.xyz, tmp, figures=not args.no_figures)
    d = result.to_dict()
    if rep.verbosity >= 0:
        line = (f"{len(d['reefs'])} reefs in {len(d['groups'])} groups, {len(d['others'])} other "
                f"objects; seabed: {d['seabed']['method']} (residual {d['seabed']['residual_rms']:.3f} m)")
        print(line)
        ev = d["evaluation"]
        if ev is not None:
            print(f"against {args.reference}: TP {ev['tp']}, FP {ev['fp']}, FN {ev['fn']}, "
                  f"correctness {100 * ev['correctness']:.2f} %, completeness "
                  f"{100 * ev['completeness']:.2f} %")
    for w in result.warnings:
        print(f"mbinspect: warning: {w}", file=sys.stderr)
    rep.info(f"results in {out}/ (report.html, reefs.json, reefs.csv, reefs.geojson)")
    return 0


# ----------------------------------------------------------------------------- parser


_EPILOG = """\
examples:
  mbinspect demo
  mbinspect piles survey.laz --count 4 --radius 0.75 --design design.csv --out piles-out
  mbinspect reefs field.laz --reference reefs.csv --out reefs-out
  mbinspect simulate jacket --seed 1 --out sim-jacket
  mbinspect info sim-jacket/soundings.xyz
  mbinspect info survey.csv --columns x,y,-,depth --depth-positive --json
"""


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``mbinspect`` command."""
    parser = _Parser(
        prog="mbinspect",
        description="Engineering answers about underwater piles and artificial reefs "
                    "from multibeam echosounder point clouds.",
        epilog=_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"mbinspect {__version__}")
    verbosity = parser.add_mutually_exclusive_group()
    verbosity.add_argument("-v", "--verbose", action="store_true", help="timings of each step")
    verbosity.add_argument("-q", "--quiet", action="store_true", help="errors only")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True

    p = sub.add_parser(
        "info", help="point count, bounds, fields, density of a cloud",
        description="Summarise a point cloud: count, bounds, z range, fields, density.",
        epilog="example:\n  mbinspect info soundings.laz --json",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    _add_input(p)
    p.add_argument("--json", action="store_true", help="print JSON instead of text")
    p.add_argument("--cell", type=float, default=1.0, metavar="M",
                   help="grid cell (m) for the covered area and density (default 1.0)")
    p.set_defaults(func=_cmd_info)

    p = sub.add_parser(
        "simulate", help="simulate a multibeam survey with exact truth",
        description="Ray-cast a multibeam survey over a scene whose piles and reefs are "
                    "known exactly; write the soundings, truth.json, labels.npz and "
                    "design.csv (jacket) or reference.csv (reef-field).",
        epilog="examples:\n  mbinspect simulate jacket --seed 3 --out sim3\n"
               "  mbinspect simulate jacket --tilt-max-deg 5 --noise-scale 2 --format laz\n"
               "  mbinspect simulate reef-field --touching-pairs 4 --sand-wave-amplitude 0.4\n"
               "  mbinspect simulate jacket --show-options",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("preset", choices=["jacket", "reef-field"])
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--out", metavar="DIR", help="output folder (default sim-PRESET-SEED)")
    p.add_argument("--format", choices=["xyz", "las", "laz", "ply", "npz"], default="xyz",
                   help="format of the soundings file (default xyz)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing --out folder")
    p.add_argument("--show-options", action="store_true",
                   help="list the preset's options and defaults, then stop")
    _add_simulate_options(p)
    p.set_defaults(func=_cmd_simulate)

    p = sub.add_parser(
        "piles", help="locate piles and every pile spacing",
        description="Locate underwater piles (top centre, radius, tilt) and every pile-to-pile "
                    "spacing; compare with a design. Writes piles.json, piles.csv, spacings.csv, "
                    "figures and report.html. Exit status 3: results written, but a pile is "
                    "flagged or a spacing fails the design tolerance.",
        epilog="examples:\n  mbinspect piles survey.laz --count 4 --radius 0.75 --design design.csv\n"
               "  mbinspect piles soundings.xyz --radius 0.75 --method both --out piles-out\n"
               "  mbinspect piles depths.csv --columns x,y,z --depth-positive --count 4 --radius 1.0",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    _add_input(p)
    _add_pile_options(p)
    p.set_defaults(func=_cmd_piles)

    p = sub.add_parser(
        "reefs", help="extract, separate, measure and score artificial reefs",
        description="Extract artificial reefs from the seabed, separate them (close and touching "
                    "ones too), measure each (centre, height, area, size, orientation, volumes), "
                    "group them and, with --reference, score them (TP/FP/FN, correctness, "
                    "completeness). Writes reefs.json, reefs.csv, reefs.geojson, figures and "
                    "report.html.",
        epilog="examples:\n  mbinspect reefs field.laz --reference reefs.csv --out reefs-out\n"
               "  mbinspect reefs field.laz --design cross2,cross1 --out reefs-out\n"
               "  mbinspect reefs soundings.xyz --method paper --no-figures",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    _add_input(p)
    _add_reef_options(p)
    p.set_defaults(func=_cmd_reefs)

    p = sub.add_parser(
        "demo", help="simulate the jacket preset and locate its piles",
        description="Simulate the jacket preset (about 2.2 M soundings) and run the whole pile "
                    "pipeline on it, printing the spacing table with errors against the truth.",
        epilog="example:\n  mbinspect demo --out demo-out",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--method", choices=["intersection", "centre", "both"], default="intersection")
    p.add_argument("--out", metavar="DIR", help="output folder (default demo-out)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing --out folder")
    p.add_argument("--no-figures", action="store_true", help="tables and JSON only")
    p.set_defaults(func=_cmd_demo)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit status."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        rep = Reporter(-1 if args.quiet else (1 if args.verbose else 0))
        result: int = args.func(args, rep)
        return result
    except MBInspectError as exc:
        print(f"mbinspect: error: {exc}", file=sys.stderr)
        return EXIT_USER
    except KeyboardInterrupt:
        print("mbinspect: interrupted", file=sys.stderr)
        return EXIT_INTERRUPT


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
