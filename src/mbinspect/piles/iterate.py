"""Stage 5, repeated: every pile measured, its points pruned to its models, measured
again, until every spacing changes by less than ``delta`` (the paper's iteration)."""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from ..errors import DataError
from .jackknife import line_jackknife
from .measure import measure_pile, prune
from .options import PileOptions
from .results import PileMeasure, PileSegment

__all__ = ["iterate", "pile_seed"]


def pile_seed(seed: int, segment: PileSegment) -> int:
    """A pile's own seed: from ``seed`` and the decimetre its soundings' centroid lies in
    (modulo 100 m, so that a survey moved by whole hectometres keeps its seeds).

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> seg = SimpleNamespace(points=np.array([[402000.03, 6000000.0, -9.0]]))
    >>> pile_seed(0, seg) == pile_seed(0, seg) != pile_seed(1, seg)
    True
    """
    c = np.asarray(segment.points, np.float64).mean(axis=0)
    q = np.floor(c[:2] * 10.0).astype(np.int64) % 1000
    return int(np.random.SeedSequence([int(seed), int(q[0]), int(q[1])]).generate_state(1)[0])


def iterate(segments: dict[int, PileSegment], side_normals: dict[int, np.ndarray], options: PileOptions,
            progress: Callable[[float], None] | None = None
            ) -> tuple[dict[int, PileMeasure], list[dict[str, Any]], dict[int, str]]:
    """Measure every pile until the spacings settle.

    Each round measures every pile not yet settled (:func:`~mbinspect.piles.measure_pile`,
    seeded by ``options.seed`` and the pile's own position, :func:`pile_seed`), records the
    centres and spacings; a pile settles when its centre moved by less than half of
    ``options.delta`` since the last round (so no spacing moves by ``delta``), else its
    points are pruned to its models; the rounds stop when every pile has settled (or after
    ``options.max_iterations``). Nothing a pile does depends on the other piles, so a pile
    measured in one tile of a survey comes out as in the whole survey.

    Parameters
    ----------
    segments : dict
        Pile id -> PileSegment.
    side_normals : dict
        Pile id -> normals of the segment's side points.
    options : PileOptions
    progress : callable, optional
        Called with the fraction of the pipeline done (0.3 to 0.9 over the rounds).

    Examples
    --------
    >>> from mbinspect.simulate import simulate
    >>> sim = simulate("jacket", seed=2, ping_spacing=0.5)
    >>> from mbinspect.piles import PileOptions, elevated_points, segment_piles, separate_piles
    >>> opts = PileOptions(radius=0.75, count=4)
    >>> up, _, _ = elevated_points(sim.cloud.xyz)
    >>> labels, _ = separate_piles(sim.cloud.xyz[up], count=4, radius=0.75)
    >>> segs, normals, _ = segment_piles(sim.cloud.xyz[up], labels, opts)
    >>> fits, rounds, unmeasured = iterate(segs, normals, opts)
    >>> len(fits), 2 <= len(rounds) <= opts.max_iterations
    (4, True)

    Returns
    -------
    measures : dict
        Pile id -> the last round's PileMeasure.
    iterations : list of dict
        Per round: ``iteration``, ``centres`` (id -> [x, y, z]) and ``spacings``
        ("a-b" -> m).
    unmeasured : dict
        Pile id -> why it could not be measured (too few top and side points); such a
        pile leaves the rounds and never stops the others.
    """
    report = progress or (lambda f: None)
    fits: dict[int, PileMeasure] = {}
    iterations: list[dict[str, Any]] = []
    active = {pid: (s.top.copy(), s.side.copy()) for pid, s in segments.items()}
    unmeasured: dict[int, str] = {}
    segments = dict(segments)
    seeds = {pid: pile_seed(options.seed, seg) for pid, seg in segments.items()}
    settled: set[int] = set()
    for it in range(1, options.max_iterations + 1):
        last = {pid: (f.x, f.y) for pid, f in fits.items()}
        for pid, seg in list(segments.items()):
            if pid in settled:
                continue
            top_m, side_m = active[pid]
            normals = side_normals[pid][side_m[seg.side]] if side_m.any() else np.zeros((0, 3))
            try:
                fits[pid] = measure_pile(seg, top_m, side_m, normals, options=options,
                                         seed=seeds[pid], previous=fits.get(pid))
            except DataError as exc:
                unmeasured[pid] = str(exc)
                del segments[pid]
                fits.pop(pid, None)
        current = {(a, b): math.hypot(fits[a].x - fits[b].x, fits[a].y - fits[b].y)
                   for a, b in itertools.combinations(sorted(fits), 2)}
        iterations.append({
            "iteration": it,
            "centres": {str(pid): [f.x, f.y, f.z] for pid, f in fits.items()},
            "spacings": {f"{a}-{b}": d for (a, b), d in current.items()},
        })
        report(0.3 + 0.6 * it / options.max_iterations)
        # each pile settles on its own when its centre moves by less than half of delta, so
        # that no spacing changes by delta; a pile's rounds do not depend on the others
        for pid in segments:
            if pid in last and math.hypot(fits[pid].x - last[pid][0], fits[pid].y - last[pid][1]) \
                    < options.delta / 2:
                settled.add(pid)
        if settled >= set(segments):
            break
        for pid, seg in segments.items():
            if pid not in settled:
                active[pid] = prune(seg, fits[pid], radius=options.radius, ks=options.ks,
                                    threshold=options.threshold)
    for pid, seg in segments.items():  # the errors each line shares, from their disagreement
        top_m, side_m = active[pid]
        normals = side_normals[pid][side_m[seg.side]] if side_m.any() else np.zeros((0, 3))
        fits[pid] = line_jackknife(seg, top_m, side_m, normals, fits[pid], options, seeds[pid])
    return fits, iterations, unmeasured
