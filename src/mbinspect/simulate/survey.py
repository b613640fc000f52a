"""A survey sailed over a scene: every ping's beams cast, their errors and backscatter."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..beam import frame, plane_range
from ..errors import ParameterError
from ..io import PointCloud
from .beam import cast_cones
from .raycast import Hits, Target, cast, heavy_noise, rays_near, targets
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
        ``beam_angle`` (deg, + starboard), ``line`` (1-based), ``ping``, and with a tide
        ``time`` (UTC, s since 1970) and heights from the water level at each ping.
    label : ndarray of int8, shape (N,)
        What each sounding hit (:data:`LABELS`).
    ident : ndarray of int32, shape (N,)
        Which pile (1-based), reef id, boulder or debris item it hit (0 = none).
    """
    sonar = plan.sonar
    if sonar.noise_scale < 0:
        raise ParameterError(f"noise_scale: {sonar.noise_scale} is negative; expected >= 0")
    rng = np.random.default_rng(seed)
    beams = sonar.beam_angles()
    track = _track(plan, seed)
    err = _errors(sonar, track, len(plan.lines), beams, rng, seed)
    all_targets = targets(scene)
    parts = []
    n_ping = len(track.pos)
    batch = max(1, 400_000 // len(beams))
    for start in range(0, n_ping, batch):
        sl = slice(start, min(start + batch, n_ping))
        parts.append(_sound(scene, sonar, track, err, beams, sl, rng, all_targets))
        if progress is not None:
            progress(sl.stop / n_ping)
    cols = (np.concatenate(c) for c in zip(*parts, strict=True))
    xyz, intensity, angle, line, ping, label, ident, utc = cols
    xyz[:, 0] += scene.origin[0]
    xyz[:, 1] += scene.origin[1]
    fields = {"intensity": intensity, "beam_angle": angle, "line": line, "ping": ping}
    if sonar.tide_range or sonar.tide_mean:  # the times a tide is applied by (else no time, as before)
        fields["time"] = utc
    cloud = PointCloud(xyz, fields)
    return cloud, label, ident


@dataclass(frozen=True)
class _Track:
    """Every ping of every line: position, heading, time, line (1-based) and the vessel's
    motion (known and compensated: it only steers where the beams go)."""

    pos: np.ndarray
    head: np.ndarray
    time: np.ndarray
    line_id: np.ndarray
    roll: np.ndarray
    pitch: np.ndarray
    heave: np.ndarray
    utc: np.ndarray


def line_times(plan: Survey) -> list[tuple[float, float]]:
    """The UTC time (s since 1970) of each line's first and last ping: the lines sailed one
    after another from the sonar's ``start_time``, a turn of ``turn_s`` between two."""
    out, start = [], plan.sonar.start_time
    for line in plan.lines:
        _, _, s = line.pings()
        end = start + (float(s[-1]) / line.speed if len(s) else 0.0)
        out.append((start, end))
        start = end + plan.sonar.turn_s
    return out


def _track(plan: Survey, seed: int | None) -> _Track:
    sonar = plan.sonar
    pos_l, head_l, dist_l, line_l, utc_l = [], [], [], [], []
    start = sonar.start_time
    for k, line in enumerate(plan.lines):
        pos, head, s = line.pings()
        pos_l.append(pos)
        head_l.append(head)
        dist_l.append(s / line.speed)
        line_l.append(np.full(len(pos), k + 1, dtype=np.int32))
        utc_l.append(start + dist_l[-1])  # the lines one after another, a turn between two
        start = float(utc_l[-1][-1]) + sonar.turn_s if len(pos) else start
    time = np.concatenate(dist_l)
    line_id = np.concatenate(line_l)
    phase = _motion_phase(sonar, len(plan.lines), seed)[line_id - 1]  # (n_ping, 3)
    roll = math.radians(sonar.roll_amplitude_deg) * np.sin(2 * np.pi * time / 7.0 + phase[:, 0])
    pitch = math.radians(sonar.pitch_amplitude_deg) * np.sin(2 * np.pi * time / 5.0 + phase[:, 1])
    heave = sonar.heave_amplitude * np.sin(2 * np.pi * time / 6.0 + phase[:, 2])
    return _Track(np.concatenate(pos_l), np.concatenate(head_l), time, line_id, roll, pitch,
                  heave, np.concatenate(utc_l))


def _motion_phase(sonar: Sonar, n_lines: int, seed: int | None) -> np.ndarray:
    """The roll, pitch and heave phases (rad) at each line's start, shape (n_lines, 3).

    The sea's phase is random: a fixed one puts the boat at the same point of its motion over
    each object in every survey at one speed, a bias that many surveys would repeat. Drawn
    from their own stream, so the other errors of a seed stay as they were.
    """
    if sonar.motion_phase == "fixed":
        return np.tile([0.3, 1.1, 0.0], (n_lines, 1))
    mrng = np.random.default_rng(np.random.SeedSequence(seed).spawn(2)[1])
    return mrng.uniform(0.0, 2 * np.pi, (n_lines, 3))


@dataclass(frozen=True)
class _Errors:
    """The errors drawn once: per ping (position, roll) and per line (height offset,
    sound-speed smile, beam biases, backscatter gain and angular fall), and the growth of
    the range noise with the beam angle."""

    dpos: np.ndarray
    droll: np.ndarray
    line_dz: np.ndarray
    line_refr: np.ndarray
    beam_bias: np.ndarray
    bs_gain: np.ndarray
    bs_fall: np.ndarray
    growth: np.ndarray


def _errors(sonar: Sonar, track: _Track, n_lines: int, beams: np.ndarray, rng: np.random.Generator,
            seed: int | None) -> _Errors:
    ns = sonar.noise_scale
    n_ping = len(track.pos)
    dpos = rng.normal(0.0, 1.0, (n_ping, 3)) * (
        np.array([sonar.position_sigma, sonar.position_sigma, sonar.vertical_sigma]) * ns
    )
    droll = rng.normal(0.0, math.radians(sonar.attitude_sigma_deg) * ns, n_ping)
    # per-line errors, from their own stream so that a model without them draws as before
    lrng = np.random.default_rng(np.random.SeedSequence(seed).spawn(1)[0])
    line_dz = lrng.normal(0.0, sonar.line_offset_sigma * ns, n_lines)
    line_refr = math.radians(sonar.refraction_bias_deg) + lrng.normal(
        0.0, math.radians(sonar.refraction_sigma_deg) * ns, n_lines)
    beam_bias = lrng.normal(0.0, sonar.beam_bias_sigma * ns, (n_lines, len(beams)))
    bs_gain = lrng.normal(0.0, sonar.bs_line_sigma_db, n_lines)
    bs_fall = sonar.bs_angle_db * lrng.uniform(0.5, 1.5, n_lines)
    growth = 1.0 + sonar.range_angle_growth * np.abs(np.sin(beams)) / math.sin(math.radians(60.0))
    return _Errors(dpos, droll, line_dz, line_refr, beam_bias, bs_gain, bs_fall, growth)


def _sound(scene: Scene, sonar: Sonar, track: _Track, err: _Errors, beams: np.ndarray, sl: slice,
           rng: np.random.Generator, all_targets: list[Target]) -> tuple[np.ndarray, ...]:
    """One batch of pings cast, measured with their errors and outliers, and given their
    backscatter: the kept soundings' xyz, intensity, beam angle, line, ping, label, ident."""
    ns = sonar.noise_scale
    m = sl.stop - sl.start
    hd = track.head[sl]
    along = np.column_stack([hd, np.zeros(m)])
    across = np.column_stack([hd[:, 1], -hd[:, 0], np.zeros(m)])  # starboard
    down = np.array([0.0, 0.0, -1.0])
    theta = beams[None, :] + track.roll[sl, None]  # (m, B)
    dirs = (np.cos(theta)[..., None] * down + np.sin(theta)[..., None] * across[:, None, :]
            + np.sin(track.pitch[sl])[:, None, None] * along[:, None, :])
    dirs /= np.linalg.norm(dirs, axis=2, keepdims=True)
    orig = np.column_stack([track.pos[sl], -sonar.draft + track.heave[sl]])
    o = np.repeat(orig, len(beams), axis=0)
    d = dirs.reshape(-1, 3)
    near = _within(all_targets, orig, scene.seabed, sonar)
    hits = cast(scene, near, o, d)
    pi = np.repeat(np.arange(sl.start, sl.stop), len(beams))
    li = track.line_id[pi] - 1
    bi = np.tile(np.arange(len(beams)), m)
    beam = beams[bi]
    # derivative of the beam direction with respect to its angle (in the swath plane)
    th = theta.reshape(-1)
    dtheta = (-np.sin(th)[:, None] * down + np.cos(th)[:, None] * np.repeat(across, len(beams), axis=0))
    if sonar.thin:
        t, label, ident, normal, materials = hits.t, hits.label, hits.ident, hits.normal, hits.materials
        cos_inc = np.clip(-np.einsum("ij,ij->i", d, normal), 0.0, 1.0)
    else:
        t, label, ident, normal, materials, cos_inc = _through_beams(sonar, near, o, d, dtheta, beam, hits)
    # detection: grazing incidences return nothing
    keep = rng.random(len(t)) < np.clip((cos_inc - 0.03) / 0.12, 0.0, 1.0)
    # measurement errors: range and pointing, growing with range and angle
    sig_r = (sonar.range_sigma + sonar.range_sigma_rel * t) * ns * err.growth[bi]
    sig_a = math.radians(sonar.angle_sigma_deg) * ns / np.cos(beam)
    bias = err.line_refr[li] * (beam / beams.max()) ** 2 * np.sign(beam)
    dang = heavy_noise(rng, len(t), sonar.tail_dof) * sig_a + err.droll[pi] + bias
    rng_meas = t + heavy_noise(rng, len(t), sonar.tail_dof) * sig_r + err.beam_bias[li, bi]
    xyz = o + rng_meas[:, None] * d + (t * dang)[:, None] * dtheta + err.dpos[pi]
    xyz[:, 2] += err.line_dz[li]
    xyz, label, ident = _outliers(xyz, label, ident, o, d, t, sonar, rng)
    if sonar.tide_range or sonar.tide_mean:  # heights from the water level at the ping, as sonars give them
        xyz[:, 2] -= sonar.tide(track.utc[pi])
    bs = _backscatter(label, ident, scene, materials, cos_inc, beam, beams, li, err, sonar, rng)
    keep &= np.isfinite(t)
    return (xyz[keep], np.round(bs[keep] + 100.0, 1), np.round(np.degrees(beam[keep]), 3),
            track.line_id[pi][keep], pi[keep].astype(np.int32) + 1, label[keep], ident[keep],
            track.utc[pi][keep])


def _through_beams(sonar: Sonar, near: list[Target], o: np.ndarray, d: np.ndarray, across: np.ndarray,
                   angle: np.ndarray, hits: Hits
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, list[str], np.ndarray]:
    """The beams' detected ranges with their width: in closed form where a cone sees only the
    seabed, from sub-rays where it may meet an object (:mod:`mbinspect.simulate.beam`).
    Returns range, label, id, normal, materials and cosine of incidence, as :func:`cast` does."""
    modes = sonar.modes(angle)
    a, b = frame(d, across)
    t = plane_range(sonar, hits.seabed_t, d, a, b, hits.seabed_normal, modes)
    label = np.full(len(t), LABELS["seabed"], np.int8)
    ident = np.zeros(len(t), np.int32)
    normal = hits.seabed_normal.copy()
    cos_inc = np.clip(-np.einsum("ij,ij->i", d, normal), 0.0, 1.0)
    materials = list(hits.materials)
    rows = np.flatnonzero(rays_near(near, o, d, hits.seabed_t, sonar.spread()))
    if len(rows):
        point = o[rows] + hits.seabed_t[rows, None] * d[rows]
        cones = cast_cones(sonar, near, o[rows], d[rows], across[rows], point, hits.seabed_normal[rows],
                           modes[rows])
        t[rows], label[rows], ident[rows] = cones.range, cones.label, cones.ident
        normal[rows], cos_inc[rows] = cones.normal, cones.cos_inc
        materials += sorted(cones.materials - set(materials))
    return t, label, ident, normal, materials, cos_inc


def _outliers(xyz: np.ndarray, label: np.ndarray, ident: np.ndarray, o: np.ndarray, d: np.ndarray,
              t: np.ndarray, sonar: Sonar, rng: np.random.Generator
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Multipath spikes (long ranges) and water-column returns (short ranges)."""
    ns = sonar.noise_scale
    u = rng.random(len(t))
    spike = u < sonar.spike_rate * ns
    wcol = (u >= sonar.spike_rate * ns) & (u < (sonar.spike_rate + sonar.water_column_rate) * ns)
    xyz[spike] = o[spike] + (t[spike] + rng.uniform(1.0, 6.0, spike.sum()))[:, None] * d[spike]
    xyz[wcol] = o[wcol] + (t[wcol] * rng.uniform(0.15, 0.9, wcol.sum()))[:, None] * d[wcol]
    label = np.where(spike | wcol, LABELS["outlier"], label).astype(np.int8)
    return xyz, label, np.where(spike | wcol, 0, ident)


def _backscatter(label: np.ndarray, ident: np.ndarray, scene: Scene, materials: list[str],
                 cos_inc: np.ndarray, beam: np.ndarray, beams: np.ndarray, li: np.ndarray, err: _Errors,
                 sonar: Sonar, rng: np.random.Generator) -> np.ndarray:
    """Backscatter (dB): material, Lambert, specular peak, speckle, the line's gain and
    angular fall; outliers weak."""
    mat_bs = np.array([MATERIAL_BS[mm] for mm in materials])
    inc = np.arccos(cos_inc)
    bs = (mat_bs[_material_of(label, ident, scene, materials)]
          + 10 * np.log10(np.maximum(cos_inc**2, 1e-3))
          + 8.0 * np.exp(-((inc / math.radians(8.0)) ** 2))
          + rng.normal(0.0, sonar.speckle_db, len(label))
          + err.bs_gain[li] - err.bs_fall[li] * np.abs(beam) / beams.max())
    return np.where(label == LABELS["outlier"], rng.normal(-45.0, 5.0, len(label)), bs)


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
