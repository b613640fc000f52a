"""``mbinspect demo``: the jacket preset simulated and its piles located."""

from __future__ import annotations

import argparse
import dataclasses
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from .common import Reporter, add_output, subcommand
from .flags import typed_parser
from .piles import finish_piles

#: The demo's survey: the lines a surveyor plans to measure every spacing to the centimetre.
DEMO_SURVEY: dict[str, Any] = {"lines": "west,east,south,north,tops,tops-ew", "line_offset": 8.0}
DEMO_TEXT = ("eight lines: the pile paper's '#' pattern 8 m outside the piles, and passes over the tops "
             "both ways, a 400 kHz sonar with real-file noise")


#: The command's name and its line in ``mbinspect --help``.
COMMAND = ("demo", "simulate the jacket preset and locate its piles")


def _cmd_demo(args: argparse.Namespace, rep: Reporter, argv: Sequence[str]) -> int:
    from ..outputs import output_dir, write_json
    from ..piles import Design, PileOptions, locate_piles
    from ..simulate import simulate

    out = Path(args.out or "demo-out")
    options = PileOptions(radius=0.75, count=4, method=args.method, seed=args.seed)
    with output_dir(out, overwrite=args.overwrite) as tmp:
        t = time.perf_counter()
        sim = simulate("jacket", seed=args.seed, progress=rep.progress("simulating the jacket survey"),
                       **DEMO_SURVEY)
        rep.info(f"simulated the jacket preset: {len(sim.cloud):,} soundings in "
                 f"{time.perf_counter() - t:.1f} s (seed {args.seed}); {DEMO_TEXT}")
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
        return finish_piles(result, sim.cloud.xyz, tmp, out, args, rep, truth=sim.truth,
                             title="mbinspect demo: a simulated four-pile jacket")


def add_parser(sub: Any) -> None:
    """``mbinspect demo``: its flags."""
    from ..piles import PileOptions

    p = subcommand(sub, *COMMAND,
             "Simulate the jacket preset (about 2.2 M soundings) and run the whole pile pipeline "
             "on it, printing the spacing table with errors against the truth.",
             "example:\n  mbinspect demo --out demo-out")
    p.add_argument("--seed", type=typed_parser(int, "seed"), default=0, help="random seed (default 0)")
    p.add_argument("--method", choices=["intersection", "centre", "both"], default="intersection",
                   help="top-centre method (default intersection)")
    add_output(p, "demo-out")
    p.set_defaults(func=_cmd_demo, options_class=PileOptions)
