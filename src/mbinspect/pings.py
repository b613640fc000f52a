"""Each ping's transducer, estimated from the ping's own soundings; pings of an export without
ping numbers, estimated from the soundings' order."""

from __future__ import annotations

import math

import numpy as np

from .errors import InputError

__all__ = ["ping_origins", "ping_geometry", "estimate_pings", "ping_keys"]


def ping_origins(points: np.ndarray, ping: np.ndarray, beam_angle: np.ndarray, *, min_beams: int = 5
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Each sounding's transducer position, estimated from its ping's soundings.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
    ping : ndarray of int, shape (N,)
    beam_angle : ndarray, shape (N,)
        Degrees from vertical (+ starboard).
    min_beams : int
        Fewest soundings, spread over at least 10° of angle, for a ping's estimate.

    Returns
    -------
    origins : ndarray, shape (N, 3)
        NaN for the soundings of pings that cannot be estimated.
    ok : ndarray of bool, shape (N,)

    Examples
    --------
    >>> ang = np.linspace(-60, 60, 41)
    >>> across = 20 * np.tan(np.radians(ang))
    >>> pts = np.column_stack([100 + across, np.full(41, 50.0), np.full(41, -20.0)])
    >>> o, ok = ping_origins(pts, np.zeros(41, int), ang)
    >>> (np.round(o[0], 6) + 0.0).tolist(), bool(ok.all())
    ([100.0, 50.0, 0.0], True)
    """
    origins, _, ok = ping_geometry(points, ping, beam_angle, min_beams=min_beams)
    return origins, ok


def ping_geometry(points: np.ndarray, ping: np.ndarray, beam_angle: np.ndarray, *, min_beams: int = 5,
                  fit: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each sounding's transducer position and its ping's swath axis (a horizontal unit vector
    to starboard), as :func:`ping_origins` estimates them; both NaN where it cannot.

    ``fit`` (bool, shape (N,)) names the soundings each ping's estimate is made from (its
    seabed: an object's soundings stand off the straight line its beams draw on a seabed, and
    a pile's top under the nadir beams would lift the transducer by the pile's height); every
    sounding of a ping so estimated gets its ping's transducer.

    Returns
    -------
    origins, axes : ndarray, shape (N, 3)
    ok : ndarray of bool, shape (N,)
    """
    pts = np.asarray(points, float)
    origins = np.full_like(pts, np.nan)
    axes = np.full_like(pts, np.nan)
    if len(pts) == 0:
        return origins, axes, np.zeros(0, bool)
    _, inv = np.unique(ping, return_inverse=True)
    inv = inv.ravel()
    rows = np.arange(len(pts)) if fit is None else np.flatnonzero(fit)
    ok, per_origin, per_axis = _per_ping(pts[rows], inv[rows], np.asarray(beam_angle, float)[rows],
                                         int(inv.max()) + 1, min_beams)
    good = ok[inv]
    origins[good], axes[good] = per_origin[inv[good]], per_axis[inv[good]]
    return origins, axes, np.isfinite(origins[:, 0])


def _per_ping(pts: np.ndarray, inv: np.ndarray, ang: np.ndarray, n_pings: int, min_beams: int
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per ping (labels ``inv`` in ``0..n_pings-1``, each ping's soundings given or none):
    whether its transducer can be estimated, the transducer (n_pings, 3) and the swath axis."""
    ok = np.zeros(n_pings, bool)
    origin, axis = np.full((n_pings, 3), np.nan), np.full((n_pings, 3), np.nan)
    if len(pts) == 0:
        return ok, origin, axis
    tan = np.tan(np.radians(np.clip(ang, -85, 85)))
    n = np.bincount(inv, minlength=n_pings).astype(float)
    # the soundings by ping, nearest nadir first: each ping's run starts at ``first``
    order = np.lexsort((np.abs(tan), inv))
    first = np.searchsorted(inv[order], np.arange(n_pings))
    has = n > 0  # the runs of the pings with soundings (the others' ranges stay empty)
    spread, low = np.full(n_pings, -np.inf), np.full(n_pings, np.inf)
    spread[has] = np.maximum.reduceat(ang[order], first[has])
    low[has] = np.minimum.reduceat(ang[order], first[has])
    usable = (n >= min_beams) & (spread - low >= 10)
    # each ping's straight line x = x0 + sx tan, y = y0 + sy tan, by least squares in closed form
    st, stt = np.bincount(inv, tan, n_pings), np.bincount(inv, tan * tan, n_pings)
    den = n * stt - st * st
    with np.errstate(divide="ignore", invalid="ignore"):
        lines = []
        for col in (pts[:, 0], pts[:, 1]):
            # centred on each ping's mean so that eastings of 10^5 m lose no precision
            mean = np.bincount(inv, col, n_pings) / n
            c = col - mean[inv]
            sc = np.bincount(inv, c, n_pings)
            slope = (n * np.bincount(inv, tan * c, n_pings) - st * sc) / den
            lines.append((mean + (sc - slope * st) / n, slope))
        (x0, sx), (y0, sy) = lines
        h = np.hypot(sx, sy)
        ok = usable & (h > 0)
        # the height from the three soundings nearest nadir (their median)
        last = len(order) - 1
        mid = order[np.minimum(first + np.where(n >= 3, 1, 0), last)]
        trio = np.sort(np.stack([pts[order[np.minimum(first + k, last)], 2] for k in range(3)]), axis=0)
        z_near = np.where(n >= 3, trio[1], pts[mid, 2])
        origin[ok] = np.column_stack([x0, y0, z_near + h])[ok]
        axis[ok] = np.column_stack([sx / h, sy / h, np.zeros(n_pings)])[ok]
    return ok, origin, axis


def estimate_pings(points: np.ndarray, *, jump: float = 20.0) -> tuple[np.ndarray, np.ndarray]:
    """Pings and beam angles of soundings that lost them (an XYZ or LAS export), from their order.

    Exports keep each ping's soundings together, beam after beam across the swath: a step
    from one sounding to the next of more than ``jump`` times the median step starts a new
    ping. Each ping's transducer is taken above the middle of its swath (along the ping's
    principal axis, beams running port to starboard in the file's order) at the water
    surface (z = 0), which gives each sounding's beam angle.
    Both are assumptions; :func:`inject` says so in a warning.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
        In file order, z elevation (depths negative).
    jump : float

    Returns
    -------
    ping : ndarray of int, shape (N,)
    beam_angle : ndarray, shape (N,)
        Degrees from vertical.

    Raises
    ------
    InputError
        No ping structure in the order (fewer than 3 pings of at least 5 soundings), or
        soundings above the surface.

    Examples
    --------
    >>> ang = np.radians(np.linspace(-60, 60, 21))
    >>> pings = [np.column_stack([20 * np.tan(ang), np.full(21, 0.5 * k), np.full(21, -20.0)])
    ...          for k in range(4)]
    >>> ping, angle = estimate_pings(np.vstack(pings))
    >>> ping[[0, 20, 21, 83]].tolist(), round(float(angle[0]), 1), round(float(angle[10]), 1)
    ([0, 0, 1, 3], -60.0, 0.0)
    """
    pts = np.asarray(points, float)
    step = np.hypot(*np.diff(pts[:, :2], axis=0).T)
    typical = float(np.median(step)) if len(step) else 0.0
    ping = np.concatenate([[0], np.cumsum(step > jump * max(typical, 1e-6))]).astype(np.int64)
    sizes = np.bincount(ping)
    if (sizes >= 5).sum() < 3:
        raise InputError("the soundings' order shows no pings (expected each ping's soundings together, "
                         "beam after beam); give a survey with ping and beam_angle fields")
    if np.median(pts[:, 2]) >= 0:
        raise InputError("the soundings lie above z = 0; expected elevations below the water surface "
                         "(negative depths) to place the transducers")
    angle = np.zeros(len(pts))
    order = np.argsort(ping, kind="stable")
    for rows in np.split(order, np.flatnonzero(np.diff(ping[order])) + 1):
        if len(rows) < 2:
            continue
        xy = pts[rows, :2] - pts[rows, :2].mean(axis=0)
        axis = np.linalg.svd(xy, full_matrices=False)[2][0]
        s = xy @ axis
        if np.corrcoef(s, np.arange(len(s)))[0, 1] < 0:  # beams run port to starboard in the order
            s = -s
        s -= 0.5 * (s.min() + s.max())
        angle[rows] = np.degrees(np.arctan2(s, np.maximum(-pts[rows, 2], 1e-3)))
    return ping, angle


def ping_keys(fields: dict[str, np.ndarray]) -> np.ndarray:
    """Each sounding's ping told apart across a survey's files and lines (their ``file``
    and ``line`` fields, where a survey has them: each file numbers its pings from its own
    start), as one integer per ping.

    Examples
    --------
    >>> ping_keys({"ping": np.array([1, 1, 2, 1]), "file": np.array([0, 0, 0, 1])}).tolist()
    [0, 0, 1, 2]
    """
    cols = [np.asarray(fields[k], np.int64) for k in ("file", "line", "ping") if k in fields]
    if len(cols) == 1:
        return cols[0]
    # the columns as one number in mixed radix (the rows' order kept): a unique of integers,
    # not of rows (3.5 s for 2.2 M soundings by rows)
    spans = [int(c.max()) - int(c.min()) + 1 if len(c) else 1 for c in cols]
    if math.prod(spans) < 2**62:
        combined = np.zeros(len(cols[0]), np.int64)
        for c, span in zip(cols, spans, strict=True):
            combined = combined * span + (c - (c.min() if len(c) else 0))
        _, key = np.unique(combined, return_inverse=True)
    else:
        _, key = np.unique(np.column_stack(cols), axis=0, return_inverse=True)
    return key.ravel()
