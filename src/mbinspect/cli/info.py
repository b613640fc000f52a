"""``mbinspect info``: count, extent, fields, density and, with ``--noise``, the seabed noise of a cloud."""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from typing import Any

from .common import Reporter, subcommand
from .flags import typed_parser
from .inputs import add_input, check_input, read_input

#: The command's name and its line in ``mbinspect --help``.
COMMAND = ("info", "point count, bounds, fields, density of a cloud")


def _cmd_info(args: argparse.Namespace, rep: Reporter, argv: Sequence[str]) -> int:
    from ..checks import positive
    from ..io import describe
    from ..outputs import to_jsonable

    if args.cell is not None:
        positive("cell", args.cell)
    check_input(args)
    cloud = read_input(args, rep)
    summary = describe(cloud, cell=args.cell)
    d = summary.to_dict()
    noise = None
    if args.noise:
        from ..noise import noise_profile

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


def add_parser(sub: Any) -> None:
    """``mbinspect info``: its flags."""
    p = subcommand(sub, *COMMAND,
             "Summarise a point cloud: count, bounds, z range, fields, density.",
             "example:\n  mbinspect info soundings.laz --json")
    add_input(p, many=True)
    p.add_argument("--json", action="store_true", help="print JSON instead of text")
    p.add_argument("--noise", action="store_true",
                   help="also the seabed noise: sigma and tails by beam angle, correlations, backscatter")
    p.add_argument("--cell", type=typed_parser(float, "cell"), default=None, metavar="M",
                   help="grid cell (m) for the covered area and density (default: about three "
                        "sounding spacings)")
    p.set_defaults(func=_cmd_info)
