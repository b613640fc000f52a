"""A survey sailed over a scene: every ping's beams cast, their errors and backscatter."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from ..errors import ParameterError
from ..io import PointCloud
from .raycast import (
    Target,
    cast,
    heavy_noise,
    targets,
)
from .scene import LABELS, MATERIAL_BS, Scene, Seabed
from .sonar import Sonar, Survey


def survey(scene: Scene, plan: Survey, *, seed: int | None = 0,
           progress: Callable[[float], None] | None = None
           ) -> tuple[PointCloud, np.ndarray, np.ndarray]:
    """Sail ``plan`` over ``scene`` and return the soundings with their truth labels.

    Parameters
    ----------
    scene : Scene
    plan : Survey
    seed : int, optional
        Seed of every random error; the same seed gives the same soundings.
    progress : callable, optional
        Called with the fraction done (0..1) after each batch of pings.

    Returns
    -------
    cloud : PointCloud
        World coordinates (``scene.origin`` added) with fields ``intensity``,
        ``beam_angle`` (deg, + starboard), ``line`` (1-based) and ``ping``.
    label : ndarray of int8, shape (N,)
        What each sounding hit (:data:`LABELS`).
    ident : ndarray of int32, shape (N,)
        Which pile (1-based), reef id, boulder or debris item it hit (0 = none).
    """
    sonar = plan.sonar
    ns = sonar.noise_scale
    if ns < 0:
        raise ParameterError(f"noise_scale: {ns} is negative; expected >= 0")
    rng = np.random.default_rng(seed)
    beams = sonar.beam_angles()
    pos_l, head_l, dist_l, line_l = [], [], [], []
    for k, line in enumerate(plan.lines):
        pos, head, s = line.pings()
        pos_l.append(pos)
        head_l.append(head)
        dist_l.append(s / line.speed)
        line_l.append(np.full(len(pos), k + 1, dtype=np.int32))
    pos = np.concatenate(pos_l)
    head = np.concatenate(head_l)
    time = np.concatenate(dist_l)
    line_id = np.concatenate(line_l)
    n_ping = len(pos)
    # vessel motion (known and compensated: it only steers where the beams go)
    roll = math.radians(sonar.roll_amplitude_deg) * np.sin(2 * np.pi * time / 7.0 + 0.3)
    pitch = math.radians(sonar.pitch_amplitude_deg) * np.sin(2 * np.pi * time / 5.0 + 1.1)
    heave = sonar.heave_amplitude * np.sin(2 * np.pi * time / 6.0)
    # per-ping errors
    dpos = rng.normal(0.0, 1.0, (n_ping, 3)) * (
        np.array([sonar.position_sigma, sonar.position_sigma, sonar.vertical_sigma]) * ns
    )
    droll = rng.normal(0.0, math.radians(sonar.attitude_sigma_deg) * ns, n_ping)
    # per-line errors, from their own stream so that a model without them draws as before
    lrng = np.random.default_rng(np.random.SeedSequence(seed).spawn(1)[0])
    n_lines = len(plan.lines)
    line_dz = lrng.normal(0.0, sonar.line_offset_sigma * ns, n_lines)
    line_refr = math.radians(sonar.refraction_bias_deg) + lrng.normal(
        0.0, math.radians(sonar.refraction_sigma_deg) * ns, n_lines)
    beam_bias = lrng.normal(0.0, sonar.beam_bias_sigma * ns, (n_lines, len(beams)))
    bs_gain = lrng.normal(0.0, sonar.bs_line_sigma_db, n_lines)
    bs_fall = sonar.bs_angle_db * lrng.uniform(0.5, 1.5, n_lines)
    growth = 1.0 + sonar.range_angle_growth * np.abs(np.sin(beams)) / math.sin(math.radians(60.0))
    all_targets = targets(scene)
    out_xyz, out_int, out_ang, out_line, out_ping, out_lab, out_id = [], [], [], [], [], [], []
    batch = max(1, 400_000 // len(beams))
    for start in range(0, n_ping, batch):
        sl = slice(start, min(start + batch, n_ping))
        m = sl.stop - sl.start
        hd = head[sl]
        along = np.column_stack([hd, np.zeros(m)])
        across = np.column_stack([hd[:, 1], -hd[:, 0], np.zeros(m)])  # starboard
        down = np.array([0.0, 0.0, -1.0])
        theta = beams[None, :] + roll[sl, None]  # (m, B)
        dirs = (np.cos(theta)[..., None] * down + np.sin(theta)[..., None] * across[:, None, :]
                + np.sin(pitch[sl])[:, None, None] * along[:, None, :])
        dirs /= np.linalg.norm(dirs, axis=2, keepdims=True)
        orig = np.column_stack([pos[sl], -sonar.draft + heave[sl]])
        o = np.repeat(orig, len(beams), axis=0)
        d = dirs.reshape(-1, 3)
        near = _within(all_targets, orig, scene.seabed, sonar)
        t, label, ident, normal, materials = cast(scene, near, o, d)
        pi = np.repeat(np.arange(sl.start, sl.stop), len(beams))
        li = line_id[pi] - 1
        bi = np.tile(np.arange(len(beams)), m)
        beam = beams[bi]
        # detection: grazing incidences return nothing
        cos_inc = np.clip(-np.einsum("ij,ij->i", d, normal), 0.0, 1.0)
        keep = rng.random(len(t)) < np.clip((cos_inc - 0.03) / 0.12, 0.0, 1.0)
        # measurement errors: range and pointing, growing with range and angle
        sig_r = (sonar.range_sigma + sonar.range_sigma_rel * t) * ns * growth[bi]
        sig_a = math.radians(sonar.angle_sigma_deg) * ns / np.cos(beam)
        bias = line_refr[li] * (beam / beams.max()) ** 2 * np.sign(beam)
        dang = heavy_noise(rng, len(t), sonar.tail_dof) * sig_a + droll[pi] + bias
        rng_meas = t + heavy_noise(rng, len(t), sonar.tail_dof) * sig_r + beam_bias[li, bi]
        # derivative of the beam direction with respect to its angle (in the swath plane)
        th = theta.reshape(-1)
        dtheta = (-np.sin(th)[:, None] * down
                  + np.cos(th)[:, None] * np.repeat(across, len(beams), axis=0))
        xyz = o + rng_meas[:, None] * d + (t * dang)[:, None] * dtheta + dpos[pi]
        xyz[:, 2] += line_dz[li]
        # outliers
        u = rng.random(len(t))
        spike = u < sonar.spike_rate * ns
        wcol = (u >= sonar.spike_rate * ns) & (u < (sonar.spike_rate + sonar.water_column_rate) * ns)
        xyz[spike] = o[spike] + (t[spike] + rng.uniform(1.0, 6.0, spike.sum()))[:, None] * d[spike]
        xyz[wcol] = o[wcol] + (t[wcol] * rng.uniform(0.15, 0.9, wcol.sum()))[:, None] * d[wcol]
        label = np.where(spike | wcol, LABELS["outlier"], label).astype(np.int8)
        ident = np.where(spike | wcol, 0, ident)
        # backscatter (dB): material, Lambert, specular peak, speckle
        mat_bs = np.array([MATERIAL_BS[mm] for mm in materials])
        inc = np.arccos(cos_inc)
        bs = (mat_bs[_material_of(label, ident, scene, materials)]
              + 10 * np.log10(np.maximum(cos_inc**2, 1e-3))
              + 8.0 * np.exp(-((inc / math.radians(8.0)) ** 2))
              + rng.normal(0.0, sonar.speckle_db, len(t))
              + bs_gain[li] - bs_fall[li] * np.abs(beam) / beams.max())
        bs = np.where(label == LABELS["outlier"], rng.normal(-45.0, 5.0, len(t)), bs)
        keep &= np.isfinite(t)
        out_xyz.append(xyz[keep])
        out_int.append(np.round(bs[keep] + 100.0, 1))
        out_ang.append(np.round(np.degrees(beam[keep]), 3))
        out_line.append(line_id[pi][keep])
        out_ping.append(pi[keep].astype(np.int32) + 1)
        out_lab.append(label[keep])
        out_id.append(ident[keep])
        if progress is not None:
            progress(sl.stop / n_ping)
    xyz = np.concatenate(out_xyz)
    xyz[:, 0] += scene.origin[0]
    xyz[:, 1] += scene.origin[1]
    cloud = PointCloud(
        xyz,
        {
            "intensity": np.concatenate(out_int),
            "beam_angle": np.concatenate(out_ang),
            "line": np.concatenate(out_line),
            "ping": np.concatenate(out_ping),
        },
    )
    return cloud, np.concatenate(out_lab), np.concatenate(out_id)


def _within(targets: list[Target], origins: np.ndarray, seabed: Seabed, sonar: Sonar) -> list[Target]:
    """The targets a batch of pings can reach: within the widest beam's reach (20 m below
    the deepest seabed under the transducers, 10° past the swath) of their plan extent;
    the others cannot be hit (the same hits, found without testing every object of a
    large scene)."""
    if len(targets) < 50:
        return targets
    depth = float(np.max(origins[:, 2] - seabed.elevation(origins[:, 0], origins[:, 1]))) + 20.0
    angle = min(math.radians(sonar.swath_deg / 2 + 10.0), math.radians(85.0))
    reach = depth * math.tan(angle) + 10.0
    x0, y0 = origins[:, :2].min(axis=0) - reach
    x1, y1 = origins[:, :2].max(axis=0) + reach
    return [tg for tg in targets
            if not (tg.bbox[1] < x0 or tg.bbox[0] > x1 or tg.bbox[3] < y0 or tg.bbox[2] > y1)]


def _material_of(label: np.ndarray, ident: np.ndarray, scene: Scene,
                 materials: list[str]) -> np.ndarray:
    """Index into ``materials`` of what each sounding hit."""
    out = np.zeros(len(label), dtype=np.intp)
    kinds = {LABELS["pile"]: [p.material for p in scene.piles],
             LABELS["boulder"]: [b.material for b in scene.boulders]}
    reef_mat = {r.id: r.material for r in scene.reefs}
    for kind, mats in kinds.items():
        sel = label == kind
        if sel.any():
            idx = np.array([materials.index(m) if m in materials else 0 for m in mats])
            out[sel] = idx[ident[sel] - 1]
    sel = label == LABELS["reef"]
    if sel.any():
        for rid in np.unique(ident[sel]):
            m = reef_mat.get(int(rid), "concrete")
            out[sel & (ident == rid)] = materials.index(m) if m in materials else 0
    sel = label == LABELS["debris"]
    if sel.any() and "steel" in materials:
        out[sel] = materials.index("steel")
    return out
