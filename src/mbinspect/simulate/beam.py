"""Cones cast into the simulator's scene: each beam's sub-rays against the objects over a plane
seabed, detected as the sonar would (the beam itself: :mod:`mbinspect.beam`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..beam import Beam, cone_directions, detect, echo_energy, frame, window
from .raycast import Target, first_object_hits
from .scene import MATERIAL_BS

__all__ = ["Cones", "cast_cones"]

@dataclass(frozen=True)
class Cones:
    """Cones cast and detected: per beam, the detected range with the objects (NaN: no echo)
    and over the seabed plane alone, what the strongest echo in the window hit (label, id,
    surface normal), the energy-weighted cosine of incidence, and the materials met."""

    range: np.ndarray
    plane_range: np.ndarray
    label: np.ndarray
    ident: np.ndarray
    normal: np.ndarray
    cos_inc: np.ndarray
    materials: frozenset[str]


def cast_cones(beam: Beam, targets: list[Target], o: np.ndarray, d: np.ndarray, across: np.ndarray,
               plane_point: np.ndarray, plane_normal: np.ndarray, modes: np.ndarray) -> Cones:
    """Cast each beam's sub-rays against ``targets`` over a plane seabed (a point and upward
    normal per beam: where the beam meets the seabed) and detect each beam's range.

    Parameters
    ----------
    beam : Beam
    targets : list of Target
        The objects (:func:`mbinspect.simulate.raycast.targets`).
    o, d : ndarray, shape (R, 3)
        Each beam's origin and unit axis.
    across : ndarray, shape (R, 3)
        A vector in each beam's swath plane, off its axis (the across-track side).
    plane_point, plane_normal : ndarray, shape (R, 3)
    modes : ndarray of int, shape (R,)
        Detection codes (:meth:`Beam.modes`).
    """
    s = beam.sub_rays**2
    a, b = frame(d, across)
    dirs = cone_directions(beam, d, a, b)
    origins = np.repeat(o, s, axis=0)
    normal = np.repeat(plane_normal, s, axis=0)
    above = np.einsum("ij,ij->i", plane_point - o, plane_normal)  # each origin's height over its plane
    height = np.repeat(above, s)
    den = np.einsum("ij,ij->i", dirs, normal)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(den < -1e-9, height / den, np.inf)
    plane_t = t.copy()
    label = np.zeros(len(t), np.int8)
    ident = np.zeros(len(t), np.int32)
    bs = np.full(len(t), MATERIAL_BS["sediment"])
    materials = set()
    for tg, idx, _, nn in first_object_hits(targets, origins, dirs, t):
        label[idx], ident[idx], normal[idx] = tg.kind, tg.ident, nn
        bs[idx] = MATERIAL_BS[tg.material]
        materials.add(tg.material)
    shape = (len(o), s)
    r0 = above / np.minimum(np.einsum("ij,ij->i", d, plane_normal), -1e-9)
    half = window(beam, r0, -np.einsum("ij,ij->i", d, plane_normal))
    cos_plane = np.clip(-den, 0.0, 1.0)  # den: each sub-ray against its plane, before any object
    cos_inc = np.clip(-np.einsum("ij,ij->i", dirs, normal), 0.0, 1.0)
    energy = echo_energy(beam, 10 ** (bs / 10), cos_inc)
    seen = detect(t.reshape(shape), energy.reshape(shape), cos_inc.reshape(shape), beam, modes, half)
    e_plane = echo_energy(beam, np.full(len(t), 10 ** (MATERIAL_BS["sediment"] / 10)), cos_plane)
    alone = detect(plane_t.reshape(shape), e_plane.reshape(shape), cos_plane.reshape(shape), beam, modes,
                   half)
    pick = np.arange(len(o)) * s + seen.strongest
    return Cones(seen.range, alone.range, label[pick], ident[pick], normal[pick], seen.cos_inc,
                 frozenset(materials))

