"""The noise of a real survey: each sounding's residual from the seabed around it, and its profile.

A sounding's residual is its elevation minus a robust local plane fitted to its ``k``
nearest other soundings (the sounding itself left out, so that its own error is not
absorbed). The profile summarises those residuals the way the simulator and the pile
weights need them: spread and tails by beam angle, the correlation between neighbouring
beams of a ping and between successive pings, the median residual across the swath
(a refraction-like shape) and the backscatter's angular response.

The local plane spans a few sounding spacings, so relief at that scale (a rock, a ripple
crest) adds to the residual: the profile of a rough seabed is an upper bound on the sonar's
noise. Ping-wide errors shared by the neighbours (heave, a roll bias) are partly removed by
the plane: the per-ping statistics say how much remains.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from .checks import check_points, integer
from .errors import InputError

__all__ = ["ANGLE_BINS", "NoiseProfile", "backscatter_anomaly", "noise_profile", "robust_sigma",
           "seabed_residuals", "trimmed_lstsq", "all_round"]

#: Beam-angle bins (degrees from vertical, either side) of the profile.
ANGLE_BINS = (0.0, 20.0, 40.0, 55.0, 65.0, 90.0)

_MAD = 1.4826  # MAD to sigma for a normal distribution


def _plane_at_centre(dx: np.ndarray, dy: np.ndarray, dz: np.ndarray, w: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Weighted least-squares planes ``dz = a + b dx + c dy``, one per row.

    Returns the coefficients (N, 3) and the variance of ``a`` per unit noise variance
    (what the plane's own error adds to a residual at its centre).
    """
    ridge = 1e-9 * (np.mean(dx ** 2 + dy ** 2, axis=1) + 1e-12)  # a line of neighbours: no slope across

    def normal(v: np.ndarray) -> np.ndarray:
        sw, sx, sy = v.sum(1), (v * dx).sum(1), (v * dy).sum(1)
        sxx, syy, sxy = (v * dx * dx).sum(1) + ridge, (v * dy * dy).sum(1) + ridge, (v * dx * dy).sum(1)
        return np.stack([np.stack([sw, sx, sy], -1), np.stack([sx, sxx, sxy], -1),
                         np.stack([sy, sxy, syy], -1)], -2)

    inv = np.linalg.inv(normal(w))
    rhs = np.stack([(w * dz).sum(1), (w * dx * dz).sum(1), (w * dy * dz).sum(1)], -1)
    coef = np.einsum("nij,nj->ni", inv, rhs)
    var_a = np.einsum("ni,nij,nj->n", inv[:, 0, :], normal(w * w), inv[:, 0, :])
    return coef, var_a


def _residuals_from(local: np.ndarray, rows: np.ndarray, tree: cKDTree, base: np.ndarray, k: int,
                    out: np.ndarray, chunk: int) -> None:
    """Residuals of ``local[rows]`` against planes through their k nearest of ``local[base]``
    (``tree`` is built on ``local[base, :2]``); a sounding never counts as its own neighbour."""
    for start in range(0, len(rows), chunk):
        these = rows[start:start + chunk]
        _, nearest = tree.query(local[these, :2], k=k + 1)
        idx = base[nearest]
        own = idx == these[:, None]  # not always first when soundings coincide
        order = np.argsort(own, axis=1, kind="stable")
        idx = np.take_along_axis(idx, order, axis=1)[:, :k]
        d = local[idx] - local[these][:, None, :]
        w = np.ones(d.shape[:2])
        for _ in range(3):  # bisquare reweighting: a spike among the neighbours does not tilt the plane
            coef, var_a = _plane_at_centre(d[..., 0], d[..., 1], d[..., 2], w)
            r = d[..., 2] - (coef[:, :1] + coef[:, 1:2] * d[..., 0] + coef[:, 2:3] * d[..., 1])
            s = _MAD * np.median(np.abs(r), axis=1, keepdims=True) + 1e-6
            u = np.clip(r / (4.685 * s), -1.0, 1.0)
            w = (1 - u ** 2) ** 2 + 1e-9
        # the sounding sits at d = 0: residual = 0 - plane(0), scaled so that its spread is the
        # sounding's own (the plane's error adds var_a; it is largest at a swath's edge)
        out[these] = -coef[:, 0] / np.sqrt(1.0 + var_a)


def seabed_residuals(points: np.ndarray, *, ping: np.ndarray | None = None, k: int = 16,
                     chunk: int = 200_000) -> np.ndarray:
    """Each sounding's elevation minus a robust plane through its ``k`` nearest other soundings.

    With ``ping`` numbers, the plane of a sounding of an even ping is fitted to odd pings'
    soundings and the other way round. A ping's own beams lie much closer together than
    pings do, so without this the neighbours would all be its own ping's and errors common
    to the ping (heave, roll) would cancel out of the residual.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
        Soundings (m): x east, y north, z up.
    ping : ndarray of int, shape (N,), optional
        Each sounding's ping number.
    k : int
        Neighbours per plane (at least 4).
    chunk : int
        Soundings solved at a time (bounds the memory).

    Returns
    -------
    ndarray, shape (N,)
        Residual (m, + above the local seabed), divided by sqrt(1 + v) where v is the
        variance the plane's own fit adds (per unit noise variance), so that for
        independent noise the residuals' spread is the soundings'.

    Raises
    ------
    InputError
        Fewer than ``k + 1`` soundings (of either parity, with ``ping``).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> xy = rng.uniform(0, 20, (4000, 2))
    >>> z = 0.1 * xy[:, 0] + rng.normal(0, 0.03, 4000)
    >>> r = seabed_residuals(np.column_stack([xy, z]))
    >>> bool(0.0285 < r.std() < 0.0315)
    True
    """
    integer("k", k, minimum=4)
    pts = check_points(points)
    n = len(pts)
    local = pts - pts.mean(axis=0)  # a local frame: the result does not depend on the origin
    out = np.empty(n)
    odd = None if ping is None else (np.asarray(ping, np.int64) % 2).astype(bool)
    if odd is None or odd.all() or not odd.any():
        # pings of one parity only (one ping, or every other ping kept): each fits its own
        groups = [(np.arange(n), np.arange(n))]
    else:
        groups = [(np.flatnonzero(~odd), np.flatnonzero(odd)), (np.flatnonzero(odd), np.flatnonzero(~odd))]
    for rows, base in groups:
        if len(rows) == 0:
            continue
        if len(base) < k + 1:
            raise InputError(f"{len(base)} soundings to fit the seabed to; expected at least {k + 1} "
                             "to measure the seabed's noise")
        _residuals_from(local, rows, cKDTree(local[base, :2]), base, k, out, chunk)
    return out


@dataclass(frozen=True)
class NoiseProfile:
    """The noise of one survey, from its seabed residuals (lengths in m, angles in degrees).

    Attributes
    ----------
    soundings : int
        Soundings measured.
    spacing : float
        Median plan distance to the nearest other sounding (m).
    sigma : float
        Robust σ of all residuals (1.4826 × median absolute residual).
    std : float
        Standard deviation of the residuals within ±10 robust σ.
    p99_ratio : float
        99th percentile of |residual| over ``sigma`` (2.58 for normal noise; larger: heavy tails).
    by_angle : tuple of dict
        Per beam-angle bin: ``angles``, ``soundings``, ``sigma``, ``p99_ratio``, ``bias``
        (median residual: the across-swath shape), ``intensity_median`` and ``intensity_spread``
        (robust σ of the backscatter, dB as stored).
    beam_correlation : float or None
        Correlation of the residuals (clipped at ±4σ) of neighbouring beams of one ping.
    ping_correlation : float or None
        Correlation of the residuals (clipped at ±4σ) of one beam in successive pings.
    ping_share : float or None
        Share of the residual variance that is common to a whole ping (heave, roll).
    """

    soundings: int
    spacing: float
    sigma: float
    std: float
    p99_ratio: float
    by_angle: tuple[dict[str, Any], ...] = field(default_factory=tuple)
    beam_correlation: float | None = None
    ping_correlation: float | None = None
    ping_share: float | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready values."""
        return {"soundings": self.soundings, "spacing": self.spacing, "sigma": self.sigma, "std": self.std,
                "p99_ratio": self.p99_ratio, "by_angle": [dict(b) for b in self.by_angle],
                "beam_correlation": self.beam_correlation, "ping_correlation": self.ping_correlation,
                "ping_share": self.ping_share}


def robust_sigma(r: np.ndarray) -> float:
    """1.4826 times the median absolute deviation: the σ of normal data, robust to tails
    (NaN for no data).

    Examples
    --------
    >>> round(robust_sigma(np.r_[np.random.default_rng(0).normal(0, 2.0, 5000), 1e6]), 1)
    2.0
    """
    return float(_MAD * np.median(np.abs(r - np.median(r)))) if len(r) else float("nan")


def backscatter_anomaly(intensity: np.ndarray, beam_angle: np.ndarray, reference: np.ndarray, *,
                        line: np.ndarray | None = None, bin_deg: float = 5.0, min_count: int = 5
                        ) -> np.ndarray | None:
    """Backscatter normalised by beam angle: each sounding's intensity minus what the
    ``reference`` soundings (a seabed) return at its angle, and on its line.

    Raw backscatter falls with the angle from nadir and its level changes from line to line
    (uncalibrated gains), so a threshold on it separates beam angles and lines as much as
    materials. The angular response is the median of the reference in ``bin_deg`` bins of
    the absolute angle (bins with fewer than ``min_count`` soundings interpolated from
    their neighbours); a line with at least ``min_count`` reference soundings then has its
    own median offset removed.

    Parameters
    ----------
    intensity, beam_angle : ndarray, shape (N,)
        Backscatter (any dB-like unit) and beam angle (deg).
    reference : ndarray of bool, shape (N,)
        The soundings whose response is the zero.
    line : ndarray, shape (N,), optional
        Survey line of each sounding.

    Returns
    -------
    ndarray, shape (N,), or None
        None when the reference holds fewer than ``min_count`` finite soundings.

    Examples
    --------
    >>> ang = np.tile(np.arange(-60.0, 61.0, 2.0), 20)
    >>> bs = -20 - 0.2 * np.abs(ang)  # a seabed darkening off nadir
    >>> bright = np.arange(len(ang)) % 10 == 0
    >>> anom = backscatter_anomaly(np.where(bright, bs + 12, bs), ang, ~bright)
    >>> round(float(np.median(anom[bright])), 1), bool(abs(np.median(anom[~bright])) < 0.2)
    (11.9, True)
    """
    inten = np.asarray(intensity, float)
    a = np.abs(np.asarray(beam_angle, float))
    ref = np.asarray(reference, bool) & np.isfinite(inten) & np.isfinite(a)
    if ref.sum() < min_count:
        return None
    b = np.floor(a / bin_deg).astype(np.int64)
    bins, inv, counts = np.unique(b[ref], return_inverse=True, return_counts=True)
    seen = inten[ref]
    med = np.array([np.median(seen[inv == i]) for i in range(len(bins))])
    ok = counts >= min_count
    if not ok.any():
        curve = np.full(len(a), np.median(inten[ref]))
    else:
        curve = np.interp(a, (bins[ok] + 0.5) * bin_deg, med[ok])
    out = inten - curve
    if line is not None:
        ln = np.asarray(line)
        for v in np.unique(ln[ref]):
            own = ref & (ln == v)
            if own.sum() >= min_count:
                out[ln == v] -= np.median(out[own])
    return out


def _pair_correlation(r: np.ndarray, key_a: np.ndarray, key_b: np.ndarray) -> float | None:
    """Correlation of residuals of soundings whose (key_a, key_b) differ by one in key_b."""
    order = np.lexsort((key_b, key_a))
    a, b, rr = key_a[order], key_b[order], r[order]
    nxt = (a[1:] == a[:-1]) & (b[1:] == b[:-1] + 1)
    if nxt.sum() < 20:
        return None
    return float(np.corrcoef(rr[:-1][nxt], rr[1:][nxt])[0, 1])


def noise_profile(points: np.ndarray, fields: dict[str, np.ndarray] | None = None, *, k: int = 16,
                  residuals: np.ndarray | None = None) -> NoiseProfile:
    """The noise profile of a survey's seabed (see the module's notes on what it covers).

    Parameters
    ----------
    points : ndarray, shape (N, 3)
    fields : dict of ndarray (N,), optional
        ``beam_angle`` (deg), ``ping``, ``beam``, ``intensity``, where the file has them.
    k : int
        Neighbours per local plane.
    residuals : ndarray, shape (N,), optional
        Residuals already computed by :func:`seabed_residuals`.

    Returns
    -------
    NoiseProfile

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> xy = rng.uniform(0, 30, (6000, 2))
    >>> p = noise_profile(np.column_stack([xy, rng.normal(0, 0.05, 6000)]))
    >>> bool(0.045 < p.sigma < 0.056), bool(2.3 < p.p99_ratio < 2.9)
    (True, True)
    """
    from .grid import sounding_spacing

    fields = fields or {}
    if residuals is None:
        residuals = seabed_residuals(points, k=k, ping=fields.get("ping"))
    r = np.asarray(residuals, float)
    sigma = robust_sigma(r)
    core = r[np.abs(r - np.median(r)) <= 10 * sigma] if sigma > 0 else r
    by_angle: list[dict[str, Any]] = []
    if "beam_angle" in fields:
        ang = np.abs(np.asarray(fields["beam_angle"], float))
        inten = np.asarray(fields["intensity"], float) if "intensity" in fields else None
        for lo, hi in zip(ANGLE_BINS[:-1], ANGLE_BINS[1:], strict=True):
            m = (ang >= lo) & (ang < hi)
            if m.sum() < 30:
                continue
            rb, sb = r[m], robust_sigma(r[m])
            row: dict[str, Any] = {"angles": [lo, hi], "soundings": int(m.sum()), "sigma": sb,
                                   "p99_ratio": float(np.quantile(np.abs(rb - np.median(rb)), 0.99) / sb)
                                   if sb > 0 else None, "bias": float(np.median(rb))}
            if inten is not None and np.isfinite(inten[m]).any():
                ib = inten[m][np.isfinite(inten[m])]
                row["intensity_median"] = float(np.median(ib))
                row["intensity_spread"] = robust_sigma(ib)
            by_angle.append(row)
    beam_corr = ping_corr = ping_share = None
    if "ping" in fields and "beam" in fields:
        ping, beam = np.asarray(fields["ping"], np.int64), np.asarray(fields["beam"], np.int64)
        clipped = np.clip(r, -4 * sigma, 4 * sigma)  # a few wild soundings do not set the correlation
        beam_corr = _pair_correlation(clipped, ping, beam)
        ping_corr = _pair_correlation(clipped, beam, ping)
    if "ping" in fields:
        uniq, inv, counts = np.unique(np.asarray(fields["ping"], np.int64), return_inverse=True,
                                      return_counts=True)
        if len(uniq) >= 3 and np.var(core) > 0:
            means = np.bincount(inv, weights=np.clip(r, -10 * sigma, 10 * sigma)) / counts
            # the variance of a ping's mean beyond what independent noise leaves in a mean of n
            shared = np.var(means) - np.mean(np.var(core) / counts)
            ping_share = float(max(0.0, shared) / np.var(core))
    return NoiseProfile(
        soundings=len(r), spacing=sounding_spacing(np.asarray(points)[:, :2]), sigma=sigma,
        std=float(np.std(core)),
        p99_ratio=float(np.quantile(np.abs(r - np.median(r)), 0.99) / sigma) if sigma > 0 else float("nan"),
        by_angle=tuple(by_angle), beam_correlation=beam_corr, ping_correlation=ping_corr,
        ping_share=ping_share)


def trimmed_lstsq(design: np.ndarray, z: np.ndarray, rounds: int, min_keep: int = 12) -> np.ndarray | None:
    """Least squares of ``z`` on ``design``, refitted ``rounds`` times to the rows within
    three robust sigmas (at least 2 cm) of the last fit; None when fewer than ``min_keep``
    rows are left.

    Examples
    --------
    >>> x = np.linspace(0.0, 1.0, 50)
    >>> z = 2.0 + x; z[7] = 9.0  # one stray
    >>> np.round(trimmed_lstsq(np.column_stack([np.ones_like(x), x]), z, 2), 6).tolist()
    [2.0, 1.0]
    """
    keep = np.ones(len(z), bool)
    coef = np.zeros(design.shape[1])
    for _ in range(rounds):
        coef = np.linalg.lstsq(design[keep], z[keep], rcond=None)[0]
        res = z - design @ coef
        keep = np.abs(res) <= max(3.0 * robust_sigma(res[keep]), 0.02)
        if keep.sum() < min_keep:
            return None
    return coef


def all_round(u: np.ndarray, v: np.ndarray, sectors: int = 6) -> bool:
    """Whether offsets ``u, v`` (m east and north of a centre) lie in at least ``sectors`` of
    the 8 directions round it: soundings that surround an object, for a seabed fitted under it.

    >>> a = np.radians(np.arange(0, 360, 60))
    >>> all_round(np.cos(a), np.sin(a)), all_round(np.cos(a[:3]), np.sin(a[:3]))
    (True, False)
    """
    return len(np.unique(np.floor((np.arctan2(v, u) + np.pi) / (np.pi / 4)).astype(int) % 8)) >= sectors
