"""Stage 6b (given the deployed designs): each reef fitted by the design that explains its
soundings, touching reefs sharing their soundings by design, fragments one design explains
joined."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace

import numpy as np
from scipy.spatial import cKDTree

from ..geometry import min_area_rectangle
from ..reef_designs import ReefDesign
from .beam import Bloom, heard_rows
from .footprint import Raster
from .measure import own_soundings, soundings_around
from .pose import DesignFit, fit_design, scale_at_bound
from .results import Reef

__all__ = ["fit_reef_design", "join_by_design", "share_by_design", "with_design"]


def fit_reef_design(points: np.ndarray, cells: np.ndarray, raster: Raster, is_reef: np.ndarray,
                    height: np.ndarray, designs: Sequence[ReefDesign], *, margin: int = 8,
                    ground: float = 0.15, max_misfit: float = 0.2, reef_height: float | None = None,
                    own: np.ndarray | None = None, window: np.ndarray | None = None,
                    bloom: Bloom | None = None) -> DesignFit | None:
    """The design that best explains one reef's soundings, fitted (:func:`fit_design`).

    The soundings are those nearest to the raster cells within ``margin`` cells of the
    reef: its own reef soundings (inside), and seabed soundings within ``ground`` m of the
    seabed and other reefs' soundings (outside). Of the designs, the one with the lowest
    cost wins; None when it leaves more than ``max_misfit`` of the soundings near its edge
    (and of the reef's own beyond it) on the wrong side or its size factor sits at a bound
    (another kind of object, a broken reef). Given the reef's measured ``reef_height``, only the designs
    whose height is within 0.3 m + 20 % of it are tried (a single-layer cross under noise
    can look like a double-layer one whose upper layer was missed; its height tells), all
    of them when none is. ``own`` may give the reef's soundings (indices into ``points``)
    and ``window`` the cells whose surroundings are searched (default: ``cells``).

    Parameters
    ----------
    points : ndarray, shape (N, 3)
        Soundings (m).
    cells : ndarray of int
        The reef's raster cells.
    raster : Raster
        The labelled footprint raster (:func:`split_reefs`).
    is_reef : ndarray of bool, shape (N,)
    height : ndarray, shape (N,)
        Heights above the seabed (m).
    designs : sequence of ReefDesign
    margin : int
        Cells around the reef whose soundings take part.
    ground : float
        Seabed soundings within this height (m) are outside soundings.
    max_misfit : float
        Largest share of edge soundings on the wrong side.
    reef_height : float, optional
        The reef's measured height (m).
    own, window : ndarray of int, optional
        The reef's soundings, and the cells searched.
    bloom : Bloom, optional
        Told the beam, the reef's bloom (:func:`~mbinspect.reefs.beam.unbloom_parts`): its
        soundings are those as heard (:func:`~mbinspect.reefs.beam.heard_rows`), and the
        design is fitted as the beam draws it, each side moved out by the bloom's reach.

    Examples
    --------
    >>> from mbinspect.simulate import simulate
    >>> sim = simulate("reef-field", seed=1, groups="cross1", per_group=4, ping_spacing=0.8,
    ...                close_pairs=0, boulders=0, debris=0)
    >>> from mbinspect.reef_designs import parse_designs
    >>> from mbinspect.reefs import fit_seabed, reef_points, split_reefs
    >>> seabed, _ = fit_seabed(sim.cloud.xyz)
    >>> is_reef, height = reef_points(sim.cloud.xyz, seabed)
    >>> parts, _, raster, _ = split_reefs(sim.cloud.xyz, is_reef, height=height)
    >>> designs = parse_designs("cross1,cross2")
    >>> fit = fit_reef_design(sim.cloud.xyz, parts[0], raster, is_reef, height, designs)
    >>> fit.design, bool(abs(fit.scale - 1) < 0.05)
    ('cross1', True)

    Returns
    -------
    DesignFit or None
    """
    if reef_height is not None and math.isfinite(reef_height):
        near = [d for d in designs if abs(d.height - reef_height) <= 0.3 + 0.2 * d.height]
        designs = near or designs
    if not designs:
        return None
    wj, wi = np.divmod(cells if window is None else window, raster.nearest.shape[1])
    idx = soundings_around(raster, wj, wi, margin)
    if own is None:
        own = own_soundings(cells, raster, is_reef) if bloom is None else \
            heard_rows(points, cells, raster, is_reef, bloom)
    inside = np.isin(idx, own)
    # seabed, and the soundings of other reefs (a touching neighbour stays outside)
    outside = (~is_reef[idx] & (np.abs(height[idx]) <= ground)) | (is_reef[idx] & ~inside)
    if inside.sum() < 5 or (inside | outside).sum() < 10:
        return None
    x0, y0 = points[own, 0].mean(), points[own, 1].mean()
    grow = None if bloom is None else bloom.grow(points, idx)
    fits = [fit_design(points[idx, :2], inside, outside, d, x0=x0, y0=y0, height=height[idx], grow=grow)
            for d in designs]
    best = min(fits, key=lambda f: f.loss)
    if best.misfit > max_misfit or scale_at_bound(best.scale):
        return None
    return best


def join_by_design(points: np.ndarray, parts: list[np.ndarray], raster: Raster,
                              is_reef: np.ndarray, height: np.ndarray, designs: Sequence[ReefDesign],
                              fits: list[DesignFit | None], heights: list[float], *,
                              max_misfit: float = 0.1, blooms: Sequence[Bloom | None] | None = None
                              ) -> tuple[list[np.ndarray], list[DesignFit | None], list[float]]:
    """Join two neighbouring parts that one fitted design explains at least as well as two.

    The thin walls of a hollow reef can fall between pings so that the reef shows as two
    parts, each of which a whole design can be laid over in more than one place. Parts
    whose centres lie closer than the largest design's diameter are fitted together; when
    one design leaves at most ``max_misfit`` of the soundings near its edge on the wrong
    side and costs no more than the two separate fits (a part no design fits costs
    without bound), they are one reef. Two reefs side by side are not: one design cannot
    hold both, and their soundings outside it cost.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
    parts : list of ndarray
        Each part's raster cells.
    raster : Raster
        The labelled footprint raster (:func:`split_reefs`).
    is_reef : ndarray of bool, shape (N,)
    height : ndarray, shape (N,)
        Heights above the seabed (m).
    designs : sequence of ReefDesign
    fits : list of DesignFit or None
        Each part's fit.
    heights : list of float
        Each part's height (m).
    max_misfit : float
    blooms : sequence of Bloom or None, optional
        Told the beam, each part's bloom (a joined part keeps the first's).

    Returns
    -------
    parts, fits, heights : lists
        The same, with joined parts in place of their pieces.
    """
    if len(parts) < 2:
        return parts, fits, heights
    nx = raster.labels.shape[1]
    cen = np.array([[(p % nx).mean(), (p // nx).mean()] for p in parts]) * raster.cell
    reach = 2 * max(d.radius for d in designs)
    pairs = sorted(cKDTree(cen).query_pairs(reach),
                   key=lambda ij: float(np.hypot(*(cen[ij[0]] - cen[ij[1]]))))
    parts, fits, heights = list(parts), list(fits), list(heights)
    alive = [True] * len(parts)
    by_name = {d.name: d for d in designs}
    for i, j in pairs:
        if not (alive[i] and alive[j]):
            continue
        fi, fj = fits[i], fits[j]
        if fi is not None and fj is not None:
            # two reefs each fitted by a design, the fitted footprints well apart: no question
            ri, rj = by_name[fi.design].radius * fi.scale, by_name[fj.design].radius * fj.scale
            if math.hypot(fi.x - fj.x, fi.y - fj.y) >= 0.8 * (ri + rj):
                continue
        union = np.concatenate([parts[i], parts[j]])
        f = fit_reef_design(points, union, raster, is_reef, height, designs,
                            reef_height=max(heights[i], heights[j]), max_misfit=max_misfit,
                            bloom=None if blooms is None else blooms[i])
        apart = sum(math.inf if g is None else g.loss for g in (fits[i], fits[j]))
        if f is not None and f.loss <= apart and all(_covers(f, by_name[f.design], parts[k], raster)
                                                     for k in (i, j)):
            parts[i], fits[i], heights[i] = union, f, max(heights[i], heights[j])
            alive[j] = False
    keep = [k for k in range(len(parts)) if alive[k]]
    return [parts[k] for k in keep], [fits[k] for k in keep], [heights[k] for k in keep]


#: A design joining two parts must hold this share of each part's cells within
#: :data:`COVER_REACH` m of its footprint: its misfit counts the soundings near its edge and the
#: parts' own beyond it as shares, and a small part lying wholly beyond would hardly move it.
COVER_SHARE, COVER_REACH = 0.5, 0.25


def _covers(fit: DesignFit, design: ReefDesign, cells: np.ndarray, raster: Raster) -> bool:
    """Whether the fitted design holds the part's cells (:data:`COVER_SHARE`)."""
    d = design.signed_distance(raster.centres(cells), *fit.origin, fit.bearing_deg, fit.scale)
    return bool(np.mean(d <= COVER_REACH) >= COVER_SHARE)


def share_by_design(points: np.ndarray, parts: Sequence[np.ndarray], raster: Raster,
                      is_reef: np.ndarray, height: np.ndarray, designs: Sequence[ReefDesign],
                      fits: list[DesignFit | None], heights: Sequence[float], rounds: int = 2,
                      blooms: Sequence[Bloom | None] | None = None) -> list[DesignFit | None]:
    """Share the soundings of touching reefs by their fitted designs, and fit again.

    Where two reefs lie close (their fitted footprints within 0.5 m), the split between
    them came from the free-form raster; each of their soundings now goes to the fitted
    design it lies deeper inside (smaller signed distance), and both are fitted again.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
    parts : sequence of ndarray
        Each reef's raster cells.
    raster : Raster
        The labelled footprint raster (:func:`split_reefs`).
    is_reef : ndarray of bool, shape (N,)
    height : ndarray, shape (N,)
    designs : sequence of ReefDesign
    fits : list of DesignFit or None
    heights : sequence of float
    rounds : int
        Rounds of sharing and fitting per pair.
    blooms : sequence of Bloom or None, optional
        Told the beam, each reef's bloom: its soundings as heard are shared.

    Returns
    -------
    list of DesignFit or None
    """
    by_name = {d.name: d for d in designs}
    fits = list(fits)
    ok = [k for k, f in enumerate(fits) if f is not None]
    if len(ok) < 2:
        return fits
    cen = np.array([[fits[k].x, fits[k].y] for k in ok])  # type: ignore[union-attr]
    rad = np.array([by_name[fits[k].design].radius * fits[k].scale for k in ok])  # type: ignore[union-attr]
    tree = cKDTree(cen)
    pairs = [(ok[a], ok[b]) for a, b in sorted(tree.query_pairs(2 * float(rad.max()) + 0.5))
             if np.hypot(*(cen[a] - cen[b])) < rad[a] + rad[b] + 0.5]
    for i, j in pairs:
        bi, bj = (None, None) if blooms is None else (blooms[i], blooms[j])
        own = np.union1d(*(own_soundings(parts[k], raster, is_reef) if b is None else
                           heard_rows(points, parts[k], raster, is_reef, b) for k, b in ((i, bi), (j, bj))))
        window = np.concatenate([parts[i], parts[j]])
        for _ in range(rounds):
            fi, fj = fits[i], fits[j]
            if fi is None or fj is None:
                break
            di = by_name[fi.design].signed_distance(points[own, :2], fi.origin[0], fi.origin[1],
                                                    fi.bearing_deg, fi.scale)
            dj = by_name[fj.design].signed_distance(points[own, :2], fj.origin[0], fj.origin[1],
                                                    fj.bearing_deg, fj.scale)
            mine = di <= dj
            if mine.all() or not mine.any():
                break
            fits[i] = fit_reef_design(points, parts[i], raster, is_reef, height, designs,
                                      reef_height=heights[i], own=own[mine], window=window, bloom=bi)
            fits[j] = fit_reef_design(points, parts[j], raster, is_reef, height, designs,
                                      reef_height=heights[j], own=own[~mine], window=window, bloom=bj)
    return fits


def with_design(reef: Reef, fit: DesignFit | None, designs: Sequence[ReefDesign] = ()) -> Reef:
    """A reef's measures with its centre, area, rectangle and outline from a fitted design,
    and the share of the design's height the seabed hides (``buried_share``: one minus the
    exposed height over the design's, at its fitted scale; from ``designs``).

    Parameters
    ----------
    reef : Reef
    fit : DesignFit or None
        None leaves the reef as it is.
    designs : sequence of ReefDesign
        The designs, for their heights.

    Returns
    -------
    Reef
    """
    if fit is None:
        return reef
    rect = min_area_rectangle(fit.outline)
    height = next((d.height for d in designs if d.name == fit.design), math.nan) * fit.scale
    buried = min(max(1.0 - reef.height / height, 0.0), 1.0) if height > 0 else math.nan
    return replace(reef, x=fit.x, y=fit.y, area=fit.area, length=rect.length, width=rect.width,
                   orientation_deg=rect.bearing_deg,
                   envelope_volume=rect.length * rect.width * reef.height,
                   outline=tuple(map(tuple, np.round(fit.outline, 3).tolist())), design=fit.design,
                   design_scale=fit.scale, design_bearing_deg=fit.bearing_deg,
                   design_misfit=fit.misfit, buried_share=buried)
