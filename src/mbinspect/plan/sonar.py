"""The sonar a plan simulates, measured from one of the user's own files: its swath, beams per
ping, ping rate and the noise of its soundings by beam angle, as ``info --noise`` measures them.

The named sonar's error model is given the growth of its range noise off nadir
(:data:`GROWTHS`) whose shape across the swath fits the file's best, and scaled so that a
flat seabed surveyed with it at the file's depth shows the file's seabed noise (the median,
over the beam-angle bins both have, of the file's robust sigma over the model's); the beam's
width is not in the soundings and stays the named sonar's.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from ..io import read
from ..noise import noise_profile
from ..simulate import Line, Scene, Seabed, Sonar, Survey, survey

__all__ = ["sonar_from_file", "GROWTHS"]

#: A model whose noise in some beam-angle bin is off the file's by more than this factor is
#: said to be (a warning of the plan).
MISFIT = 1.5

#: The growths of the range noise off nadir tried (:attr:`Sonar.range_angle_growth`).
GROWTHS = (0.0, 0.6, 1.2, 2.5, 5.0, 10.0)


def _per_ping(fields: dict[str, np.ndarray]) -> tuple[int, float | None]:
    """Median soundings per ping, and pings a second from their times where the file has them."""
    ping = np.asarray(fields["ping"])
    _, inv, counts = np.unique(ping, return_inverse=True, return_counts=True)
    rate = None
    if "time" in fields:
        t = np.bincount(inv.ravel(), np.asarray(fields["time"], float)) / counts
        dt = np.diff(np.sort(t))
        dt = dt[dt > 0]
        if len(dt) > 10:
            rate = float(1.0 / np.median(dt))
    return int(np.median(counts)), rate


def _model_sigmas(sonar: Sonar, depth: float, seed: int) -> dict[tuple[float, float], float]:
    """The model's seabed noise by beam-angle bin over a flat, smooth seabed ``depth`` m down."""
    scene = Scene(Seabed(z0=-depth, roughness=0.0, extent=400.0, seed=seed))
    ping = max(depth / 40.0, 0.05)
    line = Line(((-60.0 * ping, 0.0), (60.0 * ping, 0.0)), ping_spacing=ping)
    quiet = dataclasses.replace(sonar, spike_rate=0.0, water_column_rate=0.0)
    cloud, _, _ = survey(scene, Survey((line,), quiet), seed=seed)
    prof = noise_profile(cloud.xyz, dict(cloud.fields))
    return {tuple(b["angles"]): b["sigma"] for b in prof.by_angle}


def sonar_from_file(path: str | Path, base: Sonar, *, seed: int = 0) -> tuple[Sonar, dict[str, Any]]:
    """``base`` with the swath, beams per ping and noise of the soundings in ``path``.

    Returns
    -------
    sonar : Sonar
    measured : dict
        ``file``, ``depth`` (m), ``swath_deg``, ``n_beams``, ``ping_rate_hz`` (None without
        times), ``noise_scale`` and per angle bin the file's and the model's sigma (m).

    Raises
    ------
    InputError
        The file's soundings carry no ping numbers or beam angles (an export), or too few
        soundings of seabed to measure.
    """
    cloud = read(path)
    fields = dict(cloud.fields)
    if "beam_angle" not in fields or "ping" not in fields:
        raise InputError(f"{path}: its soundings carry no ping numbers and beam angles; expected a sonar "
                         "file (GSF, KMALL, .all, XTF, .mb56) to measure the sonar from")
    if len(cloud) < 1000:
        raise InputError(f"{path}: {len(cloud):,} soundings; expected at least 1,000 to measure the sonar "
                         "from")
    depth = float(-np.median(cloud.xyz[:, 2]))
    if not depth > 0:
        raise InputError(f"{path}: the soundings' median height is {-depth:g} m; expected elevations below "
                         "the water (negative)")
    angle = np.abs(np.asarray(fields["beam_angle"], float))
    swath = float(min(2 * np.quantile(angle, 0.995), 160.0))
    beams, rate = _per_ping(fields)
    real = {tuple(b["angles"]): b["sigma"] for b in noise_profile(cloud.xyz, fields).by_angle}
    shaped = dataclasses.replace(base, swath_deg=swath, n_beams=max(beams, 16), noise_scale=1.0)
    best = None
    for growth in GROWTHS:  # the growth off nadir whose shape fits the file's best, then the scale
        trial = dataclasses.replace(shaped, range_angle_growth=growth)
        model = _model_sigmas(trial, depth, seed)
        logs = np.log([real[k] / model[k] for k in real if k in model and model[k] > 0])
        if len(logs) and (best is None or float(np.std(logs)) < best[0] - 1e-9):
            best = (float(np.std(logs)), trial, model, float(np.exp(np.median(logs))))
    if best is None:
        raise InputError(f"{path}: no beam-angle bin with enough seabed soundings to measure its noise")
    _, shaped, model, scale = best
    sonar = dataclasses.replace(shaped, noise_scale=scale)
    measured: dict[str, Any] = {
                "file": str(path), "depth": depth, "swath_deg": swath, "n_beams": beams, "ping_rate_hz": rate,
                "noise_scale": scale, "range_angle_growth": sonar.range_angle_growth, "soundings": len(cloud),
                "by_angle": [{"angles": list(k), "file_sigma": real[k],
                              "model_sigma": model[k] * scale if k in model else None} for k in sorted(real)]}
    worst = max((max(b["file_sigma"] / b["model_sigma"], b["model_sigma"] / b["file_sigma"]), b["angles"])
                for b in measured["by_angle"] if b["model_sigma"])
    measured["misfit"] = worst[0]
    if worst[0] > MISFIT:
        measured["warning"] = (f"{path}: the sonar model follows the file's seabed noise across the swath "
                               f"only to a factor of {worst[0]:.1f} (beams at {worst[1][0]:g}-"
                               f"{worst[1][1]:g} deg); the prediction is as rough there")
    if not math.isfinite(scale) or scale <= 0:
        raise InputError(f"{path}: its seabed noise could not be measured (scale {scale}); expected a "
                         "survey of seabed")
    return sonar, measured
