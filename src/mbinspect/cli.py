"""The ``mbinspect`` command line: a thin layer over the library.

Each subcommand checks its options and its output folder before any work, reads its
input, calls one library function and writes that function's result. A user's mistake is
one line on stderr (``mbinspect: error: ...``) naming the flag, file, line or column, with
exit status 2, never a traceback; warnings are one ``mbinspect: warning: ...`` line each.
Flags of the pipelines are generated from their options classes
(:class:`~mbinspect.piles.PileOptions`, :class:`~mbinspect.reefs.ReefOptions`), so no
default is written twice. Ctrl-C and SIGTERM end a run within a second with status 130
and 143, leaving nothing partial behind (:mod:`mbinspect.interrupt`).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import re
import sys
import time
import warnings
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any, NoReturn

from .cli_survey import (
    add_inputs,
    add_soundings_parser,
    add_survey_flags,
    file_records,
    input_files,
    read_options,
    run_pipeline,
    survey_options,
)
from .errors import MBInspectError, ParameterError
from .version import __version__

__all__ = ["main", "run", "build_parser"]

EXIT_USER = 2
EXIT_FLAGGED = 3  # results written, but a pile is flagged or a spacing fails the design
EXIT_IO = 1  # the output could not be written (a full disk)
EXIT_UNDECIDED = 4  # results written, nothing fails, but a verdict is undecided at 95 %
EXIT_PIPE = 141  # the reader of our output went away (128 + SIGPIPE)


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
        """A line for the user (not with ``-q``)."""
        if self.verbosity >= 0:
            print(message, file=self.stream, flush=True)

    def debug(self, message: str) -> None:
        """A timed line (``-v`` only)."""
        if self.verbosity > 0:
            print(f"[{time.perf_counter() - self._t0:7.2f} s] {message}", file=self.stream,
                  flush=True)

    def progress(self, label: str) -> Callable[[float], None]:
        """A callback that shows ``label NN %`` for work of more than a second or two."""
        start = time.perf_counter()
        self._last = -1.0
        tty = hasattr(self.stream, "isatty") and self.stream.isatty()

        def update(fraction: float) -> None:
            if self.verbosity < 0 or time.perf_counter() - start < 1.5 and (fraction < 1 or self._last < 0):
                return  # quick work shows nothing, not even its end
            pct = int(100 * fraction)
            step = 1 if tty else 25
            if pct // step == self._last // step and fraction < 1:
                return
            self._last = pct
            end = "\r" if tty and fraction < 1 else "\n"
            print(f"{label}: {pct:3d} %", end=end, file=self.stream, flush=True)

        return update


# ----------------------------------------------------------------------------- shared pieces


def _add_input(p: argparse.ArgumentParser, many: bool = False) -> None:
    from .io import FORMAT_NAMES

    if many:
        add_inputs(p)
    else:
        p.add_argument("input", help="point cloud or sonar file (.xyz .txt .csv .las .laz .ply .npz .gsf "
                                     ".kmall .all)")
    g = p.add_argument_group("reading")
    g.add_argument("--format", choices=FORMAT_NAMES, help="file format when the extension does not say it")
    g.add_argument("--columns", metavar="MAP",
                   help="ASCII columns, e.g. x,y,z,intensity or x,y,-,z ('-' skips)")
    g.add_argument("--delimiter", metavar="D",
                   help="ASCII delimiter: ',' ';' tab or space (default: sniffed)")
    g.add_argument("--depth-positive", action="store_true",
                   help="z in the file is depth, positive down (it is negated)")
    g.add_argument("--crs", metavar="CRS",
                   help="sonar files (GSF, KMALL, .all): the projected CRS to put the soundings in "
                        "(default: the UTM zone of the data); other files: the CRS of their "
                        "coordinates when the file does not say it (e.g. EPSG:32631)")
    g.add_argument("--decimal", choices=[".", ","], help="ASCII decimal mark (default: sniffed)")
    g.add_argument("--z-up", action="store_true",
                   help="z in the file is elevation, positive up (settles a mostly positive z)")
    g.add_argument("--keep-rejected", action="store_true",
                   help="sonar files: keep the soundings the sonar or the file rejected (field 'valid')")


def _add_output(p: argparse.ArgumentParser, default: str) -> None:
    o = p.add_argument_group("output")
    o.add_argument("--out", metavar="DIR", help=f"output folder (default {default})")
    o.add_argument("--overwrite", action="store_true", help="replace an existing --out folder")
    o.add_argument("--no-figures", action="store_true", help="tables and JSON only")


def _check_input(args: argparse.Namespace) -> None:
    """The inputs expanded (several files, folders, globs) into ``args.files`` and the
    reading options checked on each, before any work (the files are read later)."""
    from .io import check_read_options

    if isinstance(args.input, list):
        args.files = input_files(args)
        args.input = str(args.files[0]) if len(args.files) == 1 else args.input
        return
    check_read_options(args.input, format=args.format, columns=args.columns, delimiter=args.delimiter)
    args.files = [Path(args.input)]


def _read_input(args: argparse.Namespace, rep: Reporter) -> Any:
    from .survey.inputs import read_survey

    t = time.perf_counter()
    cloud = read_survey(args.files, progress=rep.progress("reading"), **read_options(args))
    rep.debug(f"read {len(cloud):,} points from {len(args.files)} file(s) in {time.perf_counter() - t:.2f} s")
    return cloud


def _file_record(path: str) -> dict[str, Any]:
    """Name, size and sha256 of an input file (for ``parameters``)."""
    return file_records([Path(path)])[0]


def _provenance(result: Any, args: argparse.Namespace, argv: Sequence[str], **others: str | None) -> Any:
    """The result with the input files, the reading options and the command line added to
    its parameters."""
    params = dict(result.parameters)
    inputs = args.files if hasattr(args, "files") else [Path(args.input)]
    if len(inputs) == 1:
        params["input"] = {**params.get("input", {}), **_file_record(str(inputs[0]))}
    else:
        params["input"] = {**params.get("input", {}), "files": file_records(inputs)}
    params["reading"] = read_options(args)
    for name, path in others.items():
        if path is not None:
            params[name] = _file_record(path) if Path(path).is_file() else path
    params["command_line"] = ["mbinspect", *argv]
    return dataclasses.replace(result, parameters=params)


# ----------------------------------------------------------------------------- info


def _cmd_info(args: argparse.Namespace, rep: Reporter, argv: Sequence[str]) -> int:
    from .checks import positive
    from .io import describe
    from .outputs import to_jsonable

    if args.cell is not None:
        positive("cell", args.cell)
    _check_input(args)
    cloud = _read_input(args, rep)
    summary = describe(cloud, cell=args.cell)
    d = summary.to_dict()
    noise = None
    if args.noise:
        from .noise import noise_profile

        noise = noise_profile(cloud.xyz, cloud.fields)
        d["noise"] = noise.to_dict()
    if args.json:
        print(json.dumps(to_jsonable(d), indent=2))
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
    lines.append(f"crs         {summary.crs_name or (summary.crs or '(none)')[:70]}")
    sonar = summary.sonar
    if sonar:
        what = ", ".join(str(sonar[k]) for k in ("format", "sonar", "version") if sonar.get(k))
        lines.append(f"sonar       {what}; {sonar.get('pings')} pings, {sonar.get('lines', 1)} line(s)")
        if "beam_angle_range_deg" in sonar:
            a0, a1 = sonar["beam_angle_range_deg"]
            lines.append(f"beam angles {a0:.1f} .. {a1:.1f} deg")
        if "time_span" in sonar:
            lines.append(f"time        {sonar['time_span'][0]} .. {sonar['time_span'][1]} (UTC)")
        lines.append(f"z level     {sonar.get('level')}")
    if noise is not None:
        lines += _noise_lines(noise)
    print("\n".join(lines))
    return 0


def _noise_lines(noise: Any) -> list[str]:
    """The seabed noise of ``info --noise``, as text lines."""
    def opt(v: float | None) -> str:
        return "-" if v is None else f"{v:.2f}"

    lines = [f"noise       sigma {100 * noise.sigma:.1f} cm (robust), p99/sigma {noise.p99_ratio:.1f} "
             "(2.6 normal), against the seabed of neighbouring pings",
             f"            beam correlation {opt(noise.beam_correlation)}, ping correlation "
             f"{opt(noise.ping_correlation)}, share common to a ping {opt(noise.ping_share)}"]
    for b in noise.by_angle:
        lo, hi = b["angles"]
        bs = (f", backscatter {b['intensity_median']:.1f} +/- {b['intensity_spread']:.1f} dB"
              if "intensity_median" in b else "")
        lines.append(f"  {lo:>2.0f}-{hi:<2.0f} deg  sigma {100 * b['sigma']:.1f} cm, p99/sigma "
                     f"{opt(b['p99_ratio'])}, median {100 * b['bias']:+.1f} cm{bs} ({b['soundings']:,})")
    return lines


# ----------------------------------------------------------------------------- simulate


def _add_simulate_options(p: argparse.ArgumentParser) -> None:
    from .options import typed_parser
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
            elif kind is str:
                g.add_argument(flag, dest=f"opt_{f.name}", metavar="TEXT")
            else:
                g.add_argument(flag, dest=f"opt_{f.name}", type=typed_parser(kind, f.name),
                               metavar=kind.__name__.upper())


def _parse_bool(text: str) -> bool:
    if text.lower() in ("1", "true", "yes", "on"):
        return True
    if text.lower() in ("0", "false", "no", "off"):
        return False
    raise argparse.ArgumentTypeError(f"{text!r} is not true or false")


def _cmd_simulate(args: argparse.Namespace, rep: Reporter, argv: Sequence[str]) -> int:
    import numpy as np

    from .io import write
    from .outputs import output_dir, write_json, write_table
    from .simulate import DEFAULT_SONAR, default_options, option_fields, simulate

    names = {f.name for f in option_fields(args.preset)}
    given = {k[4:]: v for k, v in vars(args).items() if k.startswith("opt_") and v is not None}
    foreign = sorted(set(given) - names)
    if foreign:
        raise ParameterError(f"{foreign[0]}: not an option of the {args.preset} preset; expected one "
                             f"of {', '.join(sorted(names))}", option=foreign[0])
    if args.show_options:
        values = default_options(args.preset, given.get("sonar", DEFAULT_SONAR))
        for f in option_fields(args.preset):
            print(f"--{f.name.replace('_', '-'):24s} {values[f.name]}")
        return 0
    out = Path(args.out) if args.out else Path(f"sim-{args.preset}-{args.seed}")
    ext = {"xyz": ".xyz", "las": ".las", "laz": ".laz", "ply": ".ply", "npz": ".npz"}[args.format]
    if args.per_line:
        return _simulate_lines(args, given, out, ext, rep, argv)
    with output_dir(out, overwrite=args.overwrite) as tmp:
        t = time.perf_counter()
        sim = simulate(args.preset, seed=args.seed, progress=rep.progress("ray casting"),
                       force=args.force, **given)
        rep.debug(f"simulated {len(sim.cloud):,} soundings in {time.perf_counter() - t:.2f} s")
        cloud_path = tmp / f"soundings{ext}"
        write(sim.cloud, cloud_path)
        write_json({**sim.truth, "command_line": ["mbinspect", *argv]}, tmp / "truth.json")
        np.savez_compressed(tmp / "labels.npz", label=sim.labels, ident=sim.ident)
        if sim.truth.get("design"):
            cols = (["group"] if "group" in sim.truth["design"][0] else []) + ["id", "x", "y"]
            write_table(sim.truth["design"], tmp / "design.csv", cols)
        if sim.truth["reefs"]:
            rows = [{"x": x, "y": y, "id": i} for x, y, i in sim.reference_rows(seed=args.seed)]
            write_table(rows, tmp / "reference.csv", ["x", "y", "id"])
    n_obj = (f"{len(sim.truth['piles'])} piles" if sim.truth["piles"]
             else f"{len(sim.truth['reefs'])} reefs")
    rep.info(f"{args.preset}: {len(sim.cloud):,} soundings, {n_obj}, written to "
             f"{out / cloud_path.name} with truth.json")
    return 0


def _simulate_lines(args: argparse.Namespace, given: dict[str, Any], out: Path, ext: str, rep: Reporter,
                    argv: Sequence[str]) -> int:
    """``simulate --per-line``: one file per survey line, streamed line by line."""
    from .outputs import output_dir, write_json, write_table
    from .simulate import reef_reference_rows, simulate_lines

    with output_dir(out, overwrite=args.overwrite) as tmp:
        t = time.perf_counter()
        truth = simulate_lines(args.preset, tmp, seed=args.seed, suffix=ext,
                               progress=rep.progress("lines"), **given)
        write_json({**truth, "command_line": ["mbinspect", *argv]}, tmp / "truth.json")
        if truth.get("design"):
            cols = (["group"] if "group" in truth["design"][0] else []) + ["id", "x", "y"]
            write_table(truth["design"], tmp / "design.csv", cols)
        if truth["reefs"]:
            rows = [{"x": x, "y": y, "id": i} for x, y, i in reef_reference_rows(truth, seed=args.seed)]
            write_table(rows, tmp / "reference.csv", ["x", "y", "id"])
        rep.debug(f"simulated {truth['n_soundings']:,} soundings in {time.perf_counter() - t:.2f} s")
    rep.info(f"{args.preset}: {truth['n_soundings']:,} soundings in {len(truth['files'])} line files in "
             f"{out}/ with truth.json")
    return 0


# ----------------------------------------------------------------------------- inject


def _cmd_inject(args: argparse.Namespace, rep: Reporter, argv: Sequence[str]) -> int:
    import numpy as np

    from .inject import inject, read_pile_file, read_reef_file
    from .io import PointCloud, write
    from .outputs import output_dir, write_json, write_table

    _check_input(args)
    if not args.piles and not args.reefs:
        raise ParameterError("nothing to inject; give `piles` or `reefs` (or both)", option="piles")
    piles = read_pile_file(args.piles) if args.piles else []
    reefs = read_reef_file(args.reefs) if args.reefs else []
    out = Path(args.out or "inject-out")
    given = [f for f in (args.piles, args.reefs) if f]
    with output_dir(out, overwrite=args.overwrite, inputs=[args.input, *given]) as tmp:
        cloud = _read_input(args, rep)
        t = time.perf_counter()
        inj = inject(cloud.xyz, cloud.fields, piles=piles, reefs=reefs)
        rep.debug(f"injected {len(piles)} piles and {len(reefs)} reefs in {time.perf_counter() - t:.2f} s")
        injected = PointCloud(inj.xyz, dict(cloud.fields), source=cloud.source, crs=cloud.crs,
                              meta=dict(cloud.meta))
        write(injected, tmp / "soundings.npz")
        truth = {**inj.to_dict(), "survey": _file_record(args.input), "command_line": ["mbinspect", *argv]}
        write_json(truth, tmp / "truth.json")
        np.savez_compressed(tmp / "labels.npz", label=inj.labels, ident=inj.ident)
        if piles:
            write_table(inj.truth["design"], tmp / "design.csv", ["group", "id", "x", "y"])
        if reefs:
            write_table([{"x": r["x"], "y": r["y"], "id": r["id"]} for r in inj.truth["reefs"]],
                        tmp / "reference.csv", ["x", "y", "id"])
    counts = inj.truth["counts"]
    hits = [f"pile {k}: {v:,}" for k, v in counts["per_pile"].items()]
    hits += [f"reef {k}: {v:,}" for k, v in counts["per_reef"].items()]
    written = " and ".join(n for n, want in (("design.csv", piles), ("reference.csv", reefs)) if want)
    what = " and ".join(f"{len(v)} {k}" for k, v in (("piles", piles), ("reefs", reefs)) if v)
    rep.info(f"{what} injected into {len(cloud):,} soundings "
             f"({', '.join(hits)}); written to {out}/soundings.npz with truth.json and {written}")
    for note in inj.truth["warnings"]:
        print(f"mbinspect: warning: {note}", file=sys.stderr)
    if counts["without_ping_geometry"]:
        print(f"mbinspect: warning: {counts['without_ping_geometry']:,} soundings of pings too short to "
              "place their transducer were left as they were", file=sys.stderr)
    for kind in ("pile", "reef"):
        for k, v in counts[f"per_{kind}"].items():
            if v == 0:
                print(f"mbinspect: warning: {kind} {k}: no beam of the survey reaches it", file=sys.stderr)
    return 0


# ----------------------------------------------------------------------------- piles


def _add_pile_options(p: argparse.ArgumentParser) -> None:
    from .options import add_flags
    from .piles import PileOptions

    g = p.add_argument_group("piles (every option of mbinspect.piles.PileOptions)")
    g.add_argument("--design", metavar="CSV", help="design positions (id,x,y) or spacings (a,b,distance)")
    add_flags(g, PileOptions)
    add_survey_flags(p)
    _add_output(p, "piles-out")


def _finish_piles(result: Any, points: Any, tmp: Path, out: Path, args: argparse.Namespace,
                  rep: Reporter, truth: Any = None, title: str = "Pile positions and spacings") -> int:
    from .report import spacing_table, write_pile_outputs

    write_pile_outputs(result, points, tmp, figures=not args.no_figures, truth=truth, title=title)
    tp = None if truth is None else {(s["a"], s["b"]): s["distance"] for s in truth["spacings"]}
    if rep.verbosity >= 0:
        print(spacing_table(result, tp))
    for w in result.warnings:
        print(f"mbinspect: warning: {w}", file=sys.stderr)
    for p in result.piles:
        for f in p.flags:
            print(f"mbinspect: warning: pile {p.id}: {f}", file=sys.stderr)
    rep.info(f"results in {out}/ (report.html, piles.json, piles.csv, spacings.csv)")
    verdicts = [s.verdict for s in result.spacings] + [f.verdict for f in result.frames]
    if "fail" in verdicts or not result.ok:
        return EXIT_FLAGGED
    return EXIT_UNDECIDED if "undecided" in verdicts else 0


def _cmd_piles(args: argparse.Namespace, rep: Reporter, argv: Sequence[str]) -> int:
    from .options import given_options
    from .outputs import output_dir
    from .piles import PileOptions, read_design

    options = PileOptions.from_given(given_options(args, PileOptions))
    survey = survey_options(args)
    _check_input(args)
    design = read_design(args.design) if args.design else None
    out = Path(args.out or "piles-out")
    with output_dir(out, overwrite=args.overwrite, inputs=[*map(str, args.files), args.design]) as tmp:
        t = time.perf_counter()
        run = run_pipeline("piles", args, args.files, options, survey, verbosity=rep.verbosity,
                           extra={"design": design}, staging=tmp, stages=rep.progress)
        rep.debug(f"located {len(run.result.piles)} piles in {time.perf_counter() - t:.2f} s")
        result = _provenance(run.result, args, argv, design=args.design)
        return _finish_piles(result, run.points, tmp, out, args, rep)


def _cmd_demo(args: argparse.Namespace, rep: Reporter, argv: Sequence[str]) -> int:
    from .outputs import output_dir, write_json
    from .piles import Design, PileOptions, locate_piles
    from .simulate import simulate

    out = Path(args.out or "demo-out")
    options = PileOptions(radius=0.75, count=4, method=args.method, seed=args.seed)
    with output_dir(out, overwrite=args.overwrite) as tmp:
        t = time.perf_counter()
        sim = simulate("jacket", seed=args.seed, progress=rep.progress("simulating the jacket survey"))
        rep.info(f"simulated the jacket preset: {len(sim.cloud):,} soundings in "
                 f"{time.perf_counter() - t:.1f} s (seed {args.seed})")
        design = Design(positions={d["id"]: (d["x"], d["y"]) for d in sim.truth["design"]},
                        source="design of the simulated jacket")
        t = time.perf_counter()
        result = locate_piles(sim.cloud, options.replace(radius=sim.truth["piles"][0]["radius"]),
                              design=design, progress=rep.progress("piles"))
        rep.info(f"located {len(result.piles)} piles in {time.perf_counter() - t:.1f} s; spacings "
                 "against the design (22 m sides) and the simulator's truth:")
        result = dataclasses.replace(result, parameters={**result.parameters,
                                                         "command_line": ["mbinspect", *argv]})
        write_json(sim.truth, tmp / "truth.json")
        return _finish_piles(result, sim.cloud.xyz, tmp, out, args, rep, truth=sim.truth,
                             title="mbinspect demo: a simulated four-pile jacket")


# ----------------------------------------------------------------------------- reefs


def _add_reef_options(p: argparse.ArgumentParser) -> None:
    from .options import add_flags
    from .reefs import ReefOptions

    g = p.add_argument_group("reefs (every option of mbinspect.reefs.ReefOptions)")
    g.add_argument("--reference", metavar="CSV", help="reference reef positions: x,y[,id]")
    add_flags(g, ReefOptions)
    add_survey_flags(p)
    _add_output(p, "reefs-out")


def _percent(v: float | None) -> str:
    return "undefined" if v is None else f"{100 * v:.2f} %"


def _cmd_reefs(args: argparse.Namespace, rep: Reporter, argv: Sequence[str]) -> int:
    from .evaluate import read_reference
    from .options import given_options
    from .outputs import output_dir
    from .reefs import ReefOptions
    from .report import write_reef_outputs

    options = ReefOptions.from_given(given_options(args, ReefOptions))  # a bad design fails here
    survey = survey_options(args)
    _check_input(args)
    reference = read_reference(args.reference) if args.reference else None
    design_files = [s for s in (args.opt_design or "").split(",") if s.strip().lower().endswith(".json")]
    out = Path(args.out or "reefs-out")
    with output_dir(out, overwrite=args.overwrite,
                    inputs=[*map(str, args.files), args.reference, *design_files]) as tmp:
        t = time.perf_counter()
        run = run_pipeline("reefs", args, args.files, options, survey, verbosity=rep.verbosity,
                           extra={"reference": reference}, staging=tmp, stages=rep.progress)
        rep.debug(f"extracted {len(run.result.reefs)} reefs in {time.perf_counter() - t:.2f} s")
        result = _provenance(run.result, args, argv, reference=args.reference)
        write_reef_outputs(result, run.points, tmp, figures=not args.no_figures)
    d = result.to_dict()
    if rep.verbosity >= 0:
        print(f"{len(d['reefs'])} reefs in {len(d['groups'])} groups, {len(d['others'])} other "
              f"objects; seabed: {d['seabed']['method']} (residual {d['seabed']['residual_rms']:.3f} m)")
        ev = d["evaluation"]
        if ev is not None:
            print(f"against {args.reference}: TP {ev['tp']}, FP {ev['fp']}, FN {ev['fn']}, "
                  f"correctness {_percent(ev['correctness'])}, completeness {_percent(ev['completeness'])}")
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
  mbinspect reefs lines/ --workers 2 --out reefs-out        (a folder of line files, tiled on Dask)
  mbinspect soundings reefs-out/reefs.json 17 --out reef17.csv
  mbinspect simulate jacket --seed 1 --out sim-jacket
  mbinspect info sim-jacket/soundings.xyz
  mbinspect info survey.csv --columns x,y,-,depth --depth-positive --json
"""


def _sub(sub: Any, name: str, help: str, description: str, epilog: str) -> argparse.ArgumentParser:
    parser: argparse.ArgumentParser = sub.add_parser(name, help=help, description=description, epilog=epilog,
                                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    return parser


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``mbinspect`` command."""
    from .options import typed_parser

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

    p = _sub(sub, "info", "point count, bounds, fields, density of a cloud",
             "Summarise a point cloud: count, bounds, z range, fields, density.",
             "example:\n  mbinspect info soundings.laz --json")
    _add_input(p, many=True)
    p.add_argument("--json", action="store_true", help="print JSON instead of text")
    p.add_argument("--noise", action="store_true",
                   help="also the seabed noise: sigma and tails by beam angle, correlations, backscatter")
    p.add_argument("--cell", type=typed_parser(float, "cell"), default=None, metavar="M",
                   help="grid cell (m) for the covered area and density (default: about three "
                        "sounding spacings)")
    p.set_defaults(func=_cmd_info)

    p = _sub(sub, "simulate", "simulate a multibeam survey with exact truth",
             "Ray-cast a multibeam survey over a scene whose piles and reefs are known exactly; "
             "write the soundings, truth.json, labels.npz and design.csv (jacket) or reference.csv "
             "(reef-field).",
             "examples:\n  mbinspect simulate jacket --seed 3 --out sim3\n"
             "  mbinspect simulate jacket --tilt-max-deg 5 --noise-scale 2 --format laz\n"
             "  mbinspect simulate reef-field --touching-pairs 4 --sand-wave-amplitude 0.4\n"
             "  mbinspect simulate jacket --show-options")
    p.add_argument("preset", choices=["jacket", "wharf", "reef-field"])
    p.add_argument("--seed", type=typed_parser(int, "seed"), default=0, help="random seed (default 0)")
    p.add_argument("--out", metavar="DIR", help="output folder (default sim-PRESET-SEED)")
    p.add_argument("--format", choices=["xyz", "las", "laz", "ply", "npz"], default="xyz",
                   help="format of the soundings file (default xyz)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing --out folder")
    p.add_argument("--force", action="store_true",
                   help="simulate even a survey of more than 50 million soundings")
    p.add_argument("--show-options", action="store_true",
                   help="list the preset's options and defaults, then stop")
    p.add_argument("--per-line", action="store_true",
                   help="write one file per survey line (line_001.laz ...), streaming line by line: a survey "
                        "of any size in the memory of one line")
    _add_simulate_options(p)
    p.set_defaults(func=_cmd_simulate)

    p = _sub(sub, "inject", "put known piles and reefs into a real survey (its own noise and shadows)",
             "Put piles and reefs of known position into a real survey: every sounding whose beam meets "
             "an object is moved to the hit point and then along its beam by its own seabed residual, so "
             "the objects carry the survey's real noise and cast its real shadows. Uses the ping and "
             "beam angle of each sounding (GSF, KMALL, .all, or an .npz that keeps them); for an XYZ or "
             "LAS export without them, estimates them from the soundings' order, with a warning. Writes "
             "soundings.npz, truth.json (as simulate writes it), labels.npz, and design.csv (piles) "
             "or reference.csv (reefs).",
             "example:\n  mbinspect inject line.all --piles piles.csv --out injected\n"
             "  mbinspect piles injected/soundings.npz --radius 0.5 --design injected/design.csv\n"
             "  mbinspect inject line.all --reefs reefs.csv --out reefs-in\n"
             "  mbinspect reefs reefs-in/soundings.npz --reference reefs-in/reference.csv\n\n"
             "piles.csv: id,x,y,radius and top (elevation, m) or height (above the seabed, m);\n"
             "optional tilt_deg, tilt_azimuth_deg, group\n"
             "reefs.csv: id,x,y,kind (cross2, cross1, hollow, triangle, cube); optional bearing_deg,\n"
             "scale (as built / design), burial (m sunk, default 0.1), group")
    _add_input(p)
    p.add_argument("--piles", metavar="CSV", help="the piles to inject (see below)")
    p.add_argument("--reefs", metavar="CSV", help="the reefs to inject (see below)")
    p.add_argument("--out", metavar="DIR", help="output folder (default inject-out)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing --out folder")
    p.set_defaults(func=_cmd_inject)

    p = _sub(sub, "piles", "locate piles and every pile spacing",
             "Locate underwater piles (top centre, radius, tilt) and every pile-to-pile spacing; "
             "compare with a design. Writes piles.json, piles.csv, spacings.csv, figures and "
             "report.html. Exit status 3: results written, but a pile is flagged or a spacing "
             "fails the design tolerance.",
             "examples:\n  mbinspect piles survey.laz --count 4 --radius 0.75 --design design.csv\n"
             "  mbinspect piles soundings.xyz --radius 0.75 --method both --out piles-out\n"
             "  mbinspect piles depths.csv --columns x,y,z --depth-positive --count 4 --radius 1.0")
    _add_input(p, many=True)
    _add_pile_options(p)
    p.set_defaults(func=_cmd_piles)

    p = _sub(sub, "reefs", "extract, separate, measure and score artificial reefs",
             "Extract artificial reefs from the seabed, separate them (close and touching ones "
             "too), measure each (centre, height, area, size, orientation, volumes), group them "
             "and, with --reference, score them (TP/FP/FN, correctness, completeness). Writes "
             "reefs.json, reefs.csv, reefs.geojson, figures and report.html.",
             "examples:\n  mbinspect reefs field.laz --reference reefs.csv --out reefs-out\n"
             "  mbinspect reefs field.laz --design cross2,cross1 --out reefs-out\n"
             "  mbinspect reefs soundings.xyz --method paper --no-figures")
    _add_input(p, many=True)
    _add_reef_options(p)
    p.set_defaults(func=_cmd_reefs)

    p = _sub(sub, "demo", "simulate the jacket preset and locate its piles",
             "Simulate the jacket preset (about 2.2 M soundings) and run the whole pile pipeline "
             "on it, printing the spacing table with errors against the truth.",
             "example:\n  mbinspect demo --out demo-out")
    p.add_argument("--seed", type=typed_parser(int, "seed"), default=0, help="random seed (default 0)")
    p.add_argument("--method", choices=["intersection", "centre", "both"], default="intersection",
                   help="top-centre method (default intersection)")
    _add_output(p, "demo-out")
    p.set_defaults(func=_cmd_demo)

    add_soundings_parser(sub, _sub)
    return parser


# ----------------------------------------------------------------------------- main


def _flag_of(args: argparse.Namespace | None, option: str) -> str:
    """The command-line flag of a library option name, for the command run."""
    from .options import flag_names

    flags = {"out": "--out", "cell": "--cell", "columns": "--columns", "delimiter": "--delimiter",
             "format": "--format", "seed": "--seed", "design": "--design", "overwrite": "--overwrite",
             "crs": "--crs", "keep_rejected": "--keep-rejected", "z_up": "--z-up",
             "decimal": "--decimal",
             "force": "--force", "depth_positive": "--depth-positive"}
    command = getattr(args, "command", None)
    if command in ("piles", "demo"):
        from .piles import PileOptions

        flags.update(flag_names(PileOptions))
    elif command == "reefs":
        from .reefs import ReefOptions

        flags.update(flag_names(ReefOptions))
    return flags.get(option, "--" + option.replace("_", "-"))


def _message(exc: MBInspectError, args: argparse.Namespace | None) -> str:
    """The error's one line, with a library option name turned into its flag."""
    text = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
    if exc.option and text.startswith(exc.option + ":"):
        text = _flag_of(args, exc.option) + text[len(exc.option):]
    # an option named in the text as `name` is shown as its flag
    return re.sub(r"`([a-z_]+)`", lambda m: _flag_of(args, m.group(1)), text)


@contextmanager
def _one_line_warnings() -> Iterator[None]:
    """Python warnings shown as one ``mbinspect: warning: ...`` line each."""
    def show(message: Any, category: Any, filename: str, lineno: int, file: Any = None,
             line: str | None = None) -> None:
        text = re.sub(r"`([a-z_]+)`", lambda m: _flag_of(None, m.group(1)), str(message))
        print(f"mbinspect: warning: {text}", file=sys.stderr, flush=True)

    with warnings.catch_warnings():
        warnings.simplefilter("default")
        warnings.showwarning = show
        yield


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line on ``argv`` (default ``sys.argv[1:]``); return the exit status.

    Parameters
    ----------
    argv : sequence of str, optional
        The arguments, without the program name.

    Returns
    -------
    int
        0 done; 2 a user's mistake; 3 results written but a pile flagged or a spacing
        failed; 1 the output could not be written; 130 / 143 interrupted; 141 the reader of
        the output went away.

    Examples
    --------
    >>> main(["piles", "missing.xyz", "--radius", "-1"])
    2
    """
    from .interrupt import exit_status

    argv = _join_dash_values(list(sys.argv[1:] if argv is None else argv))
    args = None
    try:
        with _one_line_warnings():
            parser = build_parser()
            args = parser.parse_args(argv)
            rep = Reporter(-1 if args.quiet else (1 if args.verbose else 0))
            code: int = args.func(args, rep, argv)
            sys.stdout.flush()
            return code
    except MBInspectError as exc:
        print(f"mbinspect: error: {_message(exc, args)}", file=sys.stderr)
        return EXIT_USER
    except KeyboardInterrupt:
        print("mbinspect: interrupted", file=sys.stderr)
        return exit_status()
    except BrokenPipeError:
        # the reader went away (``mbinspect info f | head``): stop quietly
        _silence_stdout()
        return EXIT_PIPE
    except OSError as exc:
        if getattr(exc, "filename", None) is None and exc.errno is not None:
            _silence_stdout()
            print(f"mbinspect: error: cannot write the output ({exc.strerror})", file=sys.stderr)
            return EXIT_IO
        where = f"{exc.filename}: " if getattr(exc, "filename", None) else ""
        print(f"mbinspect: error: {where}{exc.strerror or exc}", file=sys.stderr)
        return EXIT_IO


def _join_dash_values(argv: list[str]) -> list[str]:
    """``--columns -,x,y,z`` as ``--columns=-,x,y,z``: argparse takes a value starting with
    '-' for a flag, and column maps and crops (negative coordinates) often start so."""
    out: list[str] = []
    skip = False
    for k, a in enumerate(argv):
        if skip:
            skip = False
            continue
        if a in ("--columns", "--crop") and k + 1 < len(argv) and argv[k + 1].startswith("-") \
                and argv[k + 1] not in ("-h", "--help"):
            out.append(f"{a}={argv[k + 1]}")
            skip = True
        else:
            out.append(a)
    return out


def _silence_stdout() -> None:
    """Point stdout at /dev/null so that the interpreter's last flush cannot fail again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):
        pass


def run() -> NoReturn:
    """The console entry point: signals handled (:mod:`mbinspect.interrupt`), then :func:`main`."""
    from .interrupt import install

    install()
    sys.exit(main())


if __name__ == "__main__":  # pragma: no cover
    run()
