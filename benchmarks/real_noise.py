"""The noise of every real file of ``../shared/real/files``: what the simulator must match.

Run: ``python benchmarks/real_noise.py [--json OUT.json]``. Per readable file, the seabed
residuals (each valid sounding minus a robust plane through its 16 nearest other soundings,
scaled so that independent noise keeps its spread; :mod:`mbinspect.noise`), summarised as:
robust σ overall and by beam angle, the tail (99th percentile of |residual| over σ; 2.58 for
normal noise), the median residual by angle (the across-swath shape), the correlation of
neighbouring beams of a ping and of one beam in successive pings, the share of the variance
common to a whole ping, and the backscatter's median and robust spread by angle.

Relief at the scale of the local plane (ripples, rocks) counts as noise here, so rough
seabeds give an upper bound. Files with fewer than 200 valid soundings are skipped. The
last rows are the simulator's presets (seed 0, the seabed soundings of line 1; defaults,
then heavy tails and wider speckle), measured the same way.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _common import real_clouds, table  # noqa: E402
from mbinspect.io import PointCloud  # noqa: E402
from mbinspect.noise import ANGLE_BINS, noise_profile  # noqa: E402
from mbinspect.simulate import simulate  # noqa: E402

#: the simulator's rows: preset and options (the default sonar is ``shallow``)
SIMULATED = [("jacket", {"sonar": "classic"}), ("jacket", {}), ("reef-field", {}),
             ("reef-field", {"sonar": "deep", "seabed": -120.0, "ping_spacing": 1.5, "line_spacing": 150.0})]

#: the real files each sonar is held to: clean (p99/σ under 10: no wall, no water column),
#: dense (under 1 m between soundings) files in its depth range
REFERENCES = {"shallow": (0.0, 60.0), "deep": (100.0, 150.0)}

#: the largest ratio of simulated to real statistic the simulator may show (issue 11)
FACTOR = 1.3


def _cm(v: float | None) -> str:
    return "-" if v is None or not np.isfinite(v) else f"{100 * v:.1f}"


def _r(v: float | None) -> str:
    return "-" if v is None or not np.isfinite(v) else f"{v:.2f}"


def _clouds(simulator: bool) -> Iterator[tuple[str, PointCloud]]:
    """The readable real files (valid soundings), then the simulator's seabed soundings."""
    for name, cloud in real_clouds():
        if len(cloud.xyz) >= 200:
            yield name, cloud
    if simulator:
        for preset, kw in SIMULATED:
            sim = simulate(preset, seed=0, **kw)
            # one line's seabed soundings: what a real line file holds (no piles, no reefs)
            keep = (sim.labels == 0) & (sim.cloud.fields["line"] == 1)
            fields = {k: v[keep] for k, v in sim.cloud.fields.items()}
            # beam numbers from the fan's angles (the simulator does not record them)
            fields["beam"] = np.unique(np.round(fields["beam_angle"], 4), return_inverse=True)[1]
            cloud = PointCloud(sim.cloud.xyz[keep], fields, meta={"sonar": "simulator"})
            yield f"sim {preset} " + (" ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}"
                                               for k, v in kw.items()) or "sonar=shallow"), cloud


def _reference(profiles: dict[str, Any], depths: tuple[float, float]) -> dict[str, Any]:
    """Median σ by angle bin and median p99/σ over the clean, dense real files in ``depths``."""
    names = [n for n, p in profiles.items() if not n.startswith("sim ")
             and depths[0] <= p["depth"] < depths[1] and p["p99_ratio"] < 10 and p["spacing"] < 1]
    by: dict[str, list[float]] = {}
    for n in names:
        for b in profiles[n]["by_angle"]:
            by.setdefault(_bin(b), []).append(b["sigma"])
    enough = min(3, len(names))
    return {"files": names, "sigma": {k: float(np.median(v)) for k, v in by.items() if len(v) >= enough},
            "p99_ratio": float(np.median([profiles[n]["p99_ratio"] for n in names]))}


def _bin(b: dict[str, Any]) -> str:
    return f"{b['angles'][0]:g}-{b['angles'][1]:g}"


def _compare(profiles: dict[str, Any], bins: list[str]) -> tuple[list[list[str]], dict[str, Any]]:
    """One row per simulator line against the real files of its sonar's depth range."""
    refs = {k: _reference(profiles, d) for k, d in REFERENCES.items()}
    rows = []
    for kind, ref in refs.items():
        rows.append([f"real {kind} (median of {len(ref['files'])})",
                     *(_cm(ref["sigma"].get(b)) for b in bins), _r(ref["p99_ratio"]), "", ""])
    for name, p in profiles.items():
        if not name.startswith("sim "):
            continue
        kind = "deep" if "sonar=deep" in name else "shallow"
        ref = refs[kind]
        by = {_bin(b): b["sigma"] for b in p["by_angle"]}
        ratios = [by[b] / ref["sigma"][b] for b in bins if b in by and b in ref["sigma"]]
        ratios.append(p["p99_ratio"] / ref["p99_ratio"])
        worst = max(max(r, 1 / r) for r in ratios)
        rows.append([name[:38], *(f"{_cm(by.get(b))} ({by[b] / ref['sigma'][b]:.2f})"
                                  if b in by and b in ref["sigma"] else _cm(by.get(b)) for b in bins),
                     f"{_r(p['p99_ratio'])} ({ratios[-1]:.2f})", f"{worst:.2f}",
                     "yes" if worst <= FACTOR else "no"])
    return rows, refs


def _figure(profiles: dict[str, Any], refs: dict[str, Any], path: Path) -> None:
    """Residual σ against |beam angle|: the real files, their median, the simulator's lines."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), sharey=False)
    for ax, (kind, ref) in zip(axes, refs.items(), strict=True):
        for n in ref["files"]:
            b = profiles[n]["by_angle"]
            ax.plot([np.mean(x["angles"]) for x in b], [100 * x["sigma"] for x in b], color="0.75", lw=0.8)
        centres = [np.mean([float(v) for v in k.split("-")]) for k in ref["sigma"]]
        ax.plot(centres, [100 * v for v in ref["sigma"].values()], "k-o", lw=2.2,
                label=f"real files, median of {len(ref['files'])}")
        for name, p in profiles.items():
            if name.startswith("sim ") and (("sonar=deep" in name) == (kind == "deep")):
                b = p["by_angle"]
                ax.plot([np.mean(x["angles"]) for x in b], [100 * x["sigma"] for x in b], "-s", lw=1.4,
                        label=name[4:])
        ax.set_title(f"{kind} water: seabed residual by beam angle")
        ax.set_xlabel("|beam angle| (deg)")
        ax.set_ylabel("robust sigma (cm)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--json", help="also write every profile to this JSON file")
    ap.add_argument("--no-simulator", action="store_true", help="leave out the simulator's rows")
    ap.add_argument("--figure", default=str(Path(__file__).parent / "figures" / "noise_by_angle.png"),
                    help="where to draw σ against beam angle, real and simulated")
    args = ap.parse_args()
    bins = [f"{lo:g}-{hi:g}" for lo, hi in zip(ANGLE_BINS[:-1], ANGLE_BINS[1:], strict=True)]
    rows, shape_rows, bs_rows, profiles = [], [], [], {}
    for name, cloud in _clouds(simulator=not args.no_simulator):
        p = noise_profile(cloud.xyz, cloud.fields)
        profiles[name] = {"sonar": cloud.meta.get("sonar"), "depth": float(-np.median(cloud.xyz[:, 2])),
                          **p.to_dict()}
        by = {f"{b['angles'][0]:g}-{b['angles'][1]:g}": b for b in p.by_angle}
        name = name[:30]
        rows.append([name, str(cloud.meta.get("sonar") or "-"), f"{-np.median(cloud.xyz[:, 2]):.0f}",
                     f"{p.soundings:,}", f"{p.spacing:.2f}", _cm(p.sigma), _r(p.p99_ratio),
                     *(_cm(by[b]["sigma"]) if b in by else "-" for b in bins),
                     _r(p.beam_correlation), _r(p.ping_correlation), _r(p.ping_share)])
        shape_rows.append([name, *(_cm(by[b]["bias"]) if b in by else "-" for b in bins),
                           *(_r(by[b]["p99_ratio"]) if b in by else "-" for b in bins)])
        if any("intensity_median" in b for b in p.by_angle):
            bs_rows.append([name, *(f"{by[b]['intensity_median']:.1f} ± {by[b]['intensity_spread']:.1f}"
                                    if b in by and "intensity_median" in by[b] else "-" for b in bins)])
    print("Seabed residual: robust sigma (cm) overall and by |beam angle| (deg); correlations\n")
    print(table(["file", "sonar", "depth m", "soundings", "spacing m", "sigma cm", "p99/sigma",
                 *(f"sigma {b}" for b in bins), "beam corr", "ping corr", "ping share"], rows))
    print("\nAcross-swath shape: median residual (cm) by |beam angle|; tail p99/sigma by angle\n")
    print(table(["file", *(f"bias {b}" for b in bins), *(f"p99/s {b}" for b in bins)], shape_rows))
    print("\nBackscatter as stored: median ± robust spread (dB) by |beam angle|\n")
    print(table(["file", *bins], bs_rows))
    if not args.no_simulator:
        rows, refs = _compare(profiles, bins[:4])
        print(f"\nSimulated against real: σ (cm) by |beam angle| and p99/σ, with the ratio to the real "
              f"median; 'within' means every ratio lies in 1/{FACTOR}..{FACTOR}\n")
        print(table(["", *(f"sigma {b}" for b in bins[:4]), "p99/sigma", "worst ratio", f"within {FACTOR}"],
                    rows))
        Path(args.figure).parent.mkdir(parents=True, exist_ok=True)
        _figure(profiles, refs, Path(args.figure))
        print(f"\nfigure: {args.figure}")
    if args.json:
        Path(args.json).write_text(json.dumps(profiles, indent=1) + "\n")


if __name__ == "__main__":
    main()
