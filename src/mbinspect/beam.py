"""The sonar's beam: a cone of finite width, and the bottom detection that turns its echo into
one range.

A beam of full −3 dB widths ``beam_across_deg`` × ``beam_along_deg`` (two-way, a Gaussian
pattern) is sampled by ``sub_rays`` × ``sub_rays`` rays spread over ±1 width on each axis. A
sub-ray's echo energy is the pattern's weight times the surface's backscatter (its material,
linear) times the cosine of its incidence (Lambert's law over the patch it lights); grazing
sub-rays return nothing. The detection turns the echo into one range, placed along the beam's
own axis, as the makers' systems do:

``amplitude``
    the energy-weighted mean range within a window around the strongest echo;
``phase``
    the range at which the echo arrives from the beam's own across-track angle (the zero
    crossing of a split aperture): a weighted fit of range against the sub-rays' across angle,
    within the same window, read at zero;
``leading-edge``
    the first range among the sub-rays within the pattern's −3 dB;
``auto``
    amplitude within ``phase_from_deg`` of nadir, phase outside (as Kongsberg and R2Sonic do).

The simulator casts sub-rays only where a cone may meet an object
(:mod:`mbinspect.simulate.beam`); a cone that sees only the seabed sees it as the plane
tangent at its centre ray's hit, whose detected range follows in closed form
(:func:`plane_range`): to second order in the beam width, the amplitude range is
``r0 (1 + (σu² + σv²) / 2)`` (the weighted variances of the tangents of the sub-rays' across and
along offsets) whatever the incidence, the phase range ``r0 (1 + σv² / 2)``; the leading edge is
the nearest −3 dB sub-ray on the plane.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .checks import fail, non_negative
from .options import CHOICES, Options, option

CHOICES["detection"] = ("auto", "amplitude", "phase", "leading-edge")

#: Detection codes per beam.
AMPLITUDE, PHASE, LEADING_EDGE = 0, 1, 2

#: Rows of sub-rays detected at once (bounds the (rows, S, S) peak search's memory).
_CHUNK = 8192


def _sub_rays(name: str, value: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 3 or value % 2 == 0:
        raise fail(name, value, "an odd whole number of at least 3")
    return value


def _width(name: str, value: float) -> float:
    value = non_negative(name, value)
    if value > 10:
        raise fail(name, value, "a beam width of 0 (a thin ray) to 10 deg")
    return value


@dataclass(frozen=True)
class Beam(Options):
    """The beam's width and the sonar's bottom detection (0 width: one thin ray per beam)."""

    beam_across_deg: float = option(0.0, unit="deg", check=_width,
                                    help="beam width across track, -3 dB two-way (0: a thin ray)")
    beam_along_deg: float = option(0.0, unit="deg", check=_width,
                                   help="beam width along track, -3 dB two-way (0: as across)")
    detection: str = option("auto", choices="detection",
                            help="bottom detection: amplitude, phase, leading-edge or auto (phase off nadir)")
    phase_from_deg: float = option(15.0, unit="deg", check="non_negative",
                                   help="beam angle from which auto detection uses the phase")
    sub_rays: int = option(5, check=_sub_rays, help="sub-rays per axis sampling each beam's cone")

    @property
    def thin(self) -> bool:
        """True when every beam is one ray (no width on either axis)."""
        return self.beam_across_deg <= 0 and self.beam_along_deg <= 0

    def widths(self) -> tuple[float, float]:
        """Across- and along-track widths (radians); an along width of 0 means the across one."""
        across = math.radians(self.beam_across_deg)
        along = math.radians(self.beam_along_deg) if self.beam_along_deg > 0 else across
        return across, along

    def grid(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The sub-rays: tangents of their across and along offsets and their pattern weights, (S,) each."""
        wa, wb = self.widths()
        k = np.linspace(-1.0, 1.0, self.sub_rays)
        a, b = np.meshgrid(k, k, indexing="ij")
        weight = np.exp(-4 * math.log(2) * (a**2 + b**2)).ravel()
        return np.tan(a.ravel() * wa), np.tan(b.ravel() * wb), weight

    def spread(self) -> float:
        """Tangent of the widest sub-ray's angle from the beam axis."""
        wa, wb = self.widths()
        return math.hypot(math.tan(wa), math.tan(wb))

    def modes(self, angle: np.ndarray) -> np.ndarray:
        """The detection code of each beam from its angle (radians from vertical)."""
        if self.detection == "auto":
            return np.where(np.abs(angle) < math.radians(self.phase_from_deg), AMPLITUDE, PHASE)
        code = {"amplitude": AMPLITUDE, "phase": PHASE, "leading-edge": LEADING_EDGE}[self.detection]
        return np.full(len(angle), code)


def frame(d: np.ndarray, across: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit vectors across and along each beam, square to its axis ``d`` (``across`` is any
    vector in the swath plane off the axis)."""
    a = across - np.einsum("ij,ij->i", across, d)[:, None] * d
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    return a, np.cross(d, a)


def cone_directions(beam: Beam, d: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Every beam's sub-ray directions, (N * S, 3), beam by beam."""
    u, v, _ = beam.grid()
    dirs = d[:, None, :] + u[None, :, None] * a[:, None, :] + v[None, :, None] * b[:, None, :]
    dirs /= np.linalg.norm(dirs, axis=2, keepdims=True)
    return dirs.reshape(-1, 3)


def plane_range(beam: Beam, r0: np.ndarray, d: np.ndarray, a: np.ndarray, b: np.ndarray,
                normal: np.ndarray, modes: np.ndarray) -> np.ndarray:
    """The detected range of cones that see only a plane (``normal`` up, met at ``r0`` by the
    axis ``d``): the closed forms of the module's notes."""
    u, v, w = beam.grid()
    su2 = float((w * u * u).sum() / w.sum())
    sv2 = float((w * v * v).sum() / w.sum())
    out = np.where(modes == PHASE, r0 * (1 + sv2 / 2), r0 * (1 + (su2 + sv2) / 2))
    le = modes == LEADING_EDGE
    if le.any():
        c = -np.einsum("ij,ij->i", d[le], normal[le])
        al = np.einsum("ij,ij->i", a[le], normal[le])
        be = np.einsum("ij,ij->i", b[le], normal[le])
        half = w >= 0.5
        uu, vv = u[half], v[half]
        denom = c[:, None] - al[:, None] * uu - be[:, None] * vv
        r = np.sqrt(1 + uu**2 + vv**2) * c[:, None] / np.where(denom > 1e-6, denom, np.nan)
        out[le] = r0[le] * np.nanmin(np.where(np.isfinite(r), r, np.inf), axis=1)
    return out


def window(beam: Beam, r0: np.ndarray, cos_inc: np.ndarray) -> np.ndarray:
    """Half-width (m) of the detection window: the range spread of a beam's footprint on the
    seabed at its incidence, and never under 10 cm (the pulse and the bottom's own relief)."""
    wa, wb = beam.widths()
    tan_inc = np.sqrt(np.maximum(1 - cos_inc**2, 0.0)) / np.maximum(cos_inc, 0.05)
    return np.maximum(0.1, r0 * (max(wa, wb) * (tan_inc + 0.3)))


@dataclass(frozen=True)
class Detection:
    """Per beam: the detected range (NaN: no echo), the sub-ray whose echo is strongest within
    the window (what the sounding is of), and the energy-weighted cosine of incidence there."""

    range: np.ndarray
    strongest: np.ndarray
    cos_inc: np.ndarray


def detect(r: np.ndarray, energy: np.ndarray, cos_inc: np.ndarray, beam: Beam, modes: np.ndarray,
           half: np.ndarray) -> Detection:
    """Detect each beam's range from its sub-rays' ranges and echo energies, (R, S) each.

    ``half`` is each beam's window half-width (:func:`window`), ``modes`` its detection code.
    """
    parts = [_detect(r[s], energy[s], cos_inc[s], beam, modes[s], half[s])
             for s in (slice(i, i + _CHUNK) for i in range(0, len(r), _CHUNK))]
    if not parts:
        return Detection(np.zeros(0), np.zeros(0, np.intp), np.zeros(0))
    return Detection(*(np.concatenate(p) for p in zip(*parts, strict=True)))


def _detect(r: np.ndarray, e: np.ndarray, ci: np.ndarray, beam: Beam, modes: np.ndarray, half: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    u, _, w = beam.grid()
    e = np.where(np.isfinite(r), e, 0.0)
    r = np.where(e > 0, r, 0.0)
    rows = np.arange(len(r))
    # near[b, i, j]: sub-ray j's range within the window round sub-ray i's (two comparisons
    # and a batched product: a quarter of the time of differences and an einsum)
    hi, lo = (r + half[:, None])[:, :, None], (r - half[:, None])[:, :, None]
    near = (r[:, None, :] <= hi) & (r[:, None, :] >= lo)
    peak = np.argmax(np.matmul(near.astype(np.float64), e[:, :, None])[:, :, 0], axis=1)
    win = near[rows, peak] & (e > 0)
    ew = np.where(win, e, 0.0)
    total = ew.sum(axis=1)
    echo = total > 0
    safe = np.where(echo, total, 1.0)
    out = (ew * r).sum(axis=1) / safe
    ph = (modes == PHASE) & echo
    if ph.any():
        out[ph] = _zero_crossing(r[ph], ew[ph], u, out[ph])
    le = (modes == LEADING_EDGE) & echo
    if le.any():
        out[le] = np.where((w >= 0.5)[None, :] & (e[le] > 0), r[le], np.inf).min(axis=1)
        out[le & ~np.isfinite(out)] = np.nan
    out[~echo] = np.nan
    return out, np.argmax(ew, axis=1), (ew * ci).sum(axis=1) / safe


def _zero_crossing(r: np.ndarray, ew: np.ndarray, u: np.ndarray, mean: np.ndarray) -> np.ndarray:
    """The range where a weighted fit of range against across angle crosses zero angle: a
    parabola where the window's sub-rays lie on both sides of the axis at three or more
    angles, a line where they lie on one side, their mean where at one angle; held within
    the window's ranges (a fit is not extrapolated past what was heard)."""
    seen = ew > 0
    lo = np.where(seen, u, np.inf).min(axis=1)
    hi = np.where(seen, u, -np.inf).max(axis=1)
    across, column = np.unique(u, return_inverse=True)  # each sub-ray's across angle, as a column
    levels = ((seen @ (column.ravel()[:, None] == np.arange(len(across)))) > 0).sum(axis=1)
    degree = np.where((lo < 0) & (hi > 0) & (levels >= 3), 2, np.where(levels >= 2, 1, 0))
    out = mean.copy()
    for deg in (1, 2):
        sel = degree == deg
        if not sel.any():
            continue
        x = np.vander(u, deg + 1, increasing=True)  # (S, deg + 1)
        g = np.einsum("rs,si,sj->rij", ew[sel], x, x) + 1e-15 * np.eye(deg + 1)
        rhs = np.einsum("rs,si,rs->ri", ew[sel], x, r[sel])
        out[sel] = np.linalg.solve(g, rhs[..., None])[:, 0, 0]
    rmin = np.where(seen, r, np.inf).min(axis=1)
    rmax = np.where(seen, r, -np.inf).max(axis=1)
    return np.clip(out, rmin, rmax)



def echo_energy(beam: Beam, strength: np.ndarray, cos_inc: np.ndarray) -> np.ndarray:
    """Each sub-ray's echo energy, beam by beam ((N * S,) in, as :func:`cone_directions`
    orders them): the pattern's weight, the surface's backscatter ``strength`` (linear) and
    Lambert's cosine; nothing from grazing incidence (cosine under 0.03)."""
    _, _, weight = beam.grid()
    lambert = np.where(cos_inc > 0.03, cos_inc, 0.0)
    return np.tile(weight, len(strength) // len(weight)) * strength * lambert


#: An object's echo over the seabed's (dB) where the soundings carry no intensity to measure it.
DEFAULT_CONTRAST_DB = 20.0


def echo_contrast_db(on: np.ndarray, off: np.ndarray) -> float:
    """An object's echo over the seabed's (dB): the median intensity (dB) of the soundings on it
    (``on``) over that of the seabed's (``off``), within 0 to 30 dB;
    :data:`DEFAULT_CONTRAST_DB` where either is empty or the medians are not finite.

    Examples
    --------
    >>> echo_contrast_db(np.array([-12.0, -11.0, -13.0]), np.array([-30.0, -29.0]))
    17.5
    """
    if len(on) == 0 or len(off) == 0:
        return DEFAULT_CONTRAST_DB
    c = float(np.nanmedian(on) - np.nanmedian(off))
    return min(max(c, 0.0), 30.0) if math.isfinite(c) else DEFAULT_CONTRAST_DB
