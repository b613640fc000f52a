"""Found piles matched to their design positions: in site coordinates one to one, or a
design in its own local frame matched to each jacket by a rigid fit."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from .design import Design
from .group import jacket_groups
from .results import PileFit

__all__ = ["apply_design", "match_design", "match_local_design"]


def match_design(piles: tuple[PileFit, ...], design: Design) -> tuple[tuple[PileFit, ...], list[str]]:
    """Give each pile its design id by one-to-one nearest matching (Hungarian).

    A pile more than 2 m from its design position is flagged; a design pile with no
    measured pile, and a measured pile with no design pile, are reported.

    Parameters
    ----------
    piles : tuple of PileFit
        The measured piles, in their measured order.
    design : Design
        A design of positions.

    Returns
    -------
    piles : tuple of PileFit
        The same piles, in the same order, with design ids (new ids above the design's for
        piles not in it).
    warnings : list of str
    """
    from scipy.optimize import linear_sum_assignment

    ids = sorted(design.positions)
    D = np.array([[math.hypot(p.x - design.positions[i][0], p.y - design.positions[i][1])
                   for i in ids] for p in piles])
    rows, cols = linear_sum_assignment(D)
    warnings = []
    new: dict[int, PileFit] = {}
    for r, c in zip(rows, cols, strict=True):
        p = piles[r]
        flags = p.flags
        if D[r, c] > 2.0:
            flags = flags + (f"{D[r, c]:.2f} m from design pile {ids[c]}",)
            warnings.append(f"pile {p.id} is {D[r, c]:.2f} m from its nearest design pile "
                            f"{ids[c]}: is the design in the same coordinate frame?")
        new[r] = replace(p, id=ids[c], flags=flags)
    unmatched_design = sorted(set(ids) - {ids[c] for c in cols})
    for i in unmatched_design:
        warnings.append(f"design pile {i} was not found in the data")
    next_id = max(ids) + 1
    out = []
    for r, p in enumerate(piles):
        if r in new:
            out.append(new[r])
        else:
            out.append(replace(p, id=next_id, flags=p.flags + ("not in the design",)))
            next_id += 1
    return tuple(out), warnings


def apply_design(piles: tuple[PileFit, ...], design: Design | None
                 ) -> tuple[tuple[PileFit, ...], dict[int, int], list[str]]:
    """The piles with the design's ids, the id map, and what does not fit the design.

    A design of positions renumbers the piles (:func:`match_design`); a design of
    spacings that names a pile id not found is reported.

    Parameters
    ----------
    piles : tuple of PileFit
    design : Design or None

    Examples
    --------
    >>> from mbinspect.piles import PileFit
    >>> measured = tuple(PileFit(i, x, 0.0, -16.0, 0.75, None, None, "centre", 50, 0, 0.0, 0.0, 0.001)
    ...                  for i, x in ((1, 22.02), (2, 0.01)))
    >>> piles, remap, warnings = apply_design(measured, Design(positions={7: (0, 0), 8: (22, 0)}))
    >>> remap, warnings
    ({1: 8, 2: 7}, [])

    Returns
    -------
    piles : tuple of PileFit
    remap : dict
        Measured id -> reported id.
    warnings : list of str
    """
    warnings: list[str] = []
    remap = {p.id: p.id for p in piles}
    if design is not None and design.positions and design.groups and not _in_site_coordinates(piles, design):
        matched, warnings = match_local_design(piles, design)
        remap = {old.id: new.id for old, new in zip(piles, matched, strict=True)}
        piles = matched
    elif design is not None and design.positions:
        matched, warnings = match_design(piles, design)
        remap = {old.id: new.id for old, new in zip(piles, matched, strict=True)}
        piles = matched
    if design is not None and design.spacings:
        known = {p.id for p in piles}
        missing = sorted({i for ab in design.spacings for i in ab} - known)
        if missing:
            warnings.append(f"design {design.source}: pile id {missing[0]} does not exist "
                            f"(piles found: {', '.join(map(str, sorted(known)))})")
    return piles, remap, warnings


def _in_site_coordinates(piles: tuple[PileFit, ...], design: Design) -> bool:
    """Whether the design's positions lie where the piles are (within 2 m, most piles)."""
    d = np.array(list(design.positions.values()), np.float64)
    near = [float(np.min(np.hypot(*(d - [p.x, p.y]).T))) for p in piles]
    return bool(np.median(near) <= 2.0) if near else True


def _rigid_rms(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """RMS (m) of the best plan rotation and shift of ``a`` onto ``b`` (rows correspond), and
    the size of that rotation (deg)."""
    a0, b0 = a - a.mean(axis=0), b - b.mean(axis=0)
    u, _, vt = np.linalg.svd(a0.T @ b0)
    r = u @ vt
    if np.linalg.det(r) < 0:  # a reflection is not a rigid move
        u[:, -1] *= -1
        r = u @ vt
    turn = abs(float(np.degrees(np.arctan2(r[0, 1], r[0, 0]))))
    return float(np.sqrt(np.mean(np.sum((a0 @ r - b0) ** 2, axis=1)))), turn


def match_local_design(piles: tuple[PileFit, ...], design: Design) -> tuple[tuple[PileFit, ...], list[str]]:
    """Design ids for piles whose design is drawn in a local frame, jacket by jacket.

    The piles are grouped by their spacing (:func:`~mbinspect.piles.jacket_groups`); each
    design group is paired with a measured jacket of as many piles, and within it each pile
    with a design pile, by the correspondence whose best rigid plan move leaves the
    smallest misfit (every ordering is tried: a jacket has a handful of piles). Where
    jackets share a shape, design group N goes to the N-th jacket from the west; a symmetric
    jacket (a square, a rectangle) fits as well turned by its symmetry, and then the
    correspondence that turns the drawing least is taken: draw the design roughly as the
    jacket lies, and number the groups west to east.

    Parameters
    ----------
    piles : tuple of PileFit
    design : Design
        Positions in any frame, and the group of each id.

    Returns
    -------
    piles : tuple of PileFit
        Same order, design ids (new ids above the design's for piles not matched).
    warnings : list of str

    Examples
    --------
    >>> from mbinspect.piles import PileFit
    >>> local = Design(positions={1: (0, 0), 2: (12, 0), 3: (1, 14), 4: (11, 14)},
    ...                groups={1: 1, 2: 1, 3: 1, 4: 1})
    >>> site = [(500011.0, 514.0), (500000.0, 500.0), (500001.0, 514.0), (500012.0, 500.0)]
    >>> ps = tuple(PileFit(k + 1, x, y, -8.0, 0.6, None, None, "centre", 50, 0, 0.0, 0.0, 0.001)
    ...            for k, (x, y) in enumerate(site))
    >>> [p.id for p in match_local_design(ps, local)[0]]
    [4, 1, 3, 2]
    """
    import itertools


    xy = np.array([[p.x, p.y] for p in piles])
    labels = jacket_groups(xy)
    warnings: list[str] = []
    new_ids: dict[int, int] = {}
    free = set(int(g) for g in np.unique(labels))
    for g in sorted(set(design.groups.values())):
        ids = sorted(i for i, gg in design.groups.items() if gg == g)
        dxy = np.array([design.positions[i] for i in ids], np.float64)
        per_jacket: dict[int, tuple[float, float, tuple[int, ...]]] = {}
        for m in sorted(free):
            idx = np.flatnonzero(labels == m)
            if len(idx) != len(ids) or len(ids) > 7:
                continue
            fits = [(*_rigid_rms(dxy, xy[list(perm)]), tuple(int(i) for i in perm))
                    for perm in itertools.permutations(idx)]
            low = min(f[0] for f in fits)
            # a symmetric jacket fits as well turned: of the near-best, the smallest turn
            per_jacket[m] = min((f for f in fits if f[0] <= low + 0.02), key=lambda f: f[1])
        best = None
        if per_jacket:
            low = min(f[0] for f in per_jacket.values())
            # jackets of one shape fit each other's drawing within their as-built scatter:
            # then the jacket of the design's own number (counted west to east)
            near = [m for m, f in per_jacket.items() if f[0] <= low + 0.1]
            m = g if g in near else min(per_jacket, key=lambda k: per_jacket[k][0])
            best = (per_jacket[m][0], m, per_jacket[m][2])
        if best is None:
            warnings.append(f"design group {g}: no measured jacket of {len(ids)} piles to match it with")
            continue
        free.discard(best[1])
        if best[0] > 0.5:
            warnings.append(f"design group {g}: its best match misses by {best[0]:.2f} m RMS: is it the "
                            "right design?")
        for design_id, k in zip(ids, best[2], strict=True):
            new_ids[int(k)] = design_id
    next_id = max(design.positions) + 1
    out = []
    for k, p in enumerate(piles):
        if k in new_ids:
            out.append(replace(p, id=new_ids[k]))
        else:
            out.append(replace(p, id=next_id, flags=p.flags + ("not in the design",)))
            next_id += 1
    return tuple(out), warnings
