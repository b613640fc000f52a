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

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _common import real_clouds, table  # noqa: E402
from mbinspect.io import PointCloud  # noqa: E402
from mbinspect.noise import ANGLE_BINS, noise_profile  # noqa: E402
from mbinspect.simulate import simulate  # noqa: E402

#: the simulator's rows: preset and options
SIMULATED = [("jacket", {}), ("reef-field", {}), ("reef-field", {"tail_dof": 2.5, "speckle_db": 5})]


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
            yield f"sim {preset} " + (" ".join(f"{k}={v}" for k, v in kw.items()) or "default"), cloud


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--json", help="also write every profile to this JSON file")
    ap.add_argument("--no-simulator", action="store_true", help="leave out the simulator's rows")
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
    if args.json:
        Path(args.json).write_text(json.dumps(profiles, indent=1) + "\n")


if __name__ == "__main__":
    main()
