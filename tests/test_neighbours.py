"""The cell index's neighbour searches against SciPy's KD-tree, to the bit."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from mbinspect import neighbours
from mbinspect.cellsort import DENSE_CELLS_PER_POINT, floor_cells, segment_percentile
from mbinspect.grid import cell_percentile, cell_segments
from mbinspect.neighbours import Cells, count_within, kth_distance, nearest_within


def _cloud(n: int, extent: float, seed: int) -> np.ndarray:
    """Millimetre soundings (ties of distance are common), some of them repeated."""
    rng = np.random.default_rng(seed)
    p = rng.uniform(0, extent, (n, 3)) + [500_000.0, 6_200_000.0, -20.0]
    p[:, 2] = -20.0 + rng.normal(0, 0.2, n)
    p[n // 2:n // 2 + n // 20] = p[:n // 20]
    return np.round(p, 3)


@pytest.mark.parametrize("extent, side", [(8.0, 0.5), (400.0, 0.5), (5.0, 2.0)])
@pytest.mark.parametrize("plan", [False, True])
def test_kth_distance_is_the_trees(extent, side, plan):
    p = _cloud(3000, extent, 1)
    cells = Cells.build(p, side)
    assert cells.dense == (cells.nx * cells.ny <= DENSE_CELLS_PER_POINT * len(p) + (1 << 16))
    tree = cKDTree(p[:, :2] if plan else p)
    for k in (1, 2, 5, 17):
        want = tree.query(p[:, :2] if plan else p, k=k)[0]
        want = want[:, -1] if want.ndim == 2 else want
        assert np.array_equal(kth_distance(cells, p, k, plan=plan), want)
    # points that are not soundings, some outside the cloud's cells
    rng = np.random.default_rng(2)
    q = p[:50] + rng.normal(0, 0.7 * extent, (50, 3))
    want = tree.query(q[:, :2] if plan else q, k=3)[0][:, -1]
    assert np.array_equal(kth_distance(cells, q, 3, plan=plan), want)


@pytest.mark.parametrize("extent", [8.0, 400.0])
def test_count_within_is_the_trees(extent):
    p = _cloud(3000, extent, 3)
    local = p - p.mean(axis=0)
    tree = cKDTree(local)
    rng = np.random.default_rng(4)
    for side in (0.5, 0.5005):
        cells = Cells.build(local, side)
        for r in (0.3, 0.5, 1.7):
            # strict: a KD-tree's distance_upper_bound
            d = tree.query(local, k=6, distance_upper_bound=r)[0]
            assert np.array_equal(count_within(cells, local, r, 6), np.isfinite(d).sum(axis=1))
        # at most the radius, each point its own radius: the tree's distances <= it
        radius = rng.uniform(0.1, 2.0, len(local))
        d = tree.query(local, k=40)[0]
        want = np.minimum((d <= radius[:, None]).sum(axis=1), 40)
        assert np.array_equal(count_within(cells, local, radius, 40, strict=False), want)


@pytest.mark.parametrize("plan", [False, True])
def test_a_few_soundings_far_apart_are_searched_pair_by_pair_and_as_the_tree(plan, monkeypatch):
    """A tile of a deep survey: 40 soundings tens of metres apart in cells sized for shallow
    water (a ring search would visit every empty cell between them); every pair is taken at
    once, with the tree's answers, to the bit, and the rings' too."""
    p = _cloud(40, 600.0, 5)
    cells = Cells.build(p, 0.2)
    assert not cells.dense and neighbours._few(cells, p)
    tree = cKDTree(p[:, :2] if plan else p)
    rng = np.random.default_rng(6)
    q = np.vstack([p, p[:20] + rng.normal(0, 50.0, (20, 3))])
    got = {}
    for rings in (False, True):
        if rings:  # the ring searches on the same (small) problem: the same answers
            monkeypatch.setattr(neighbours, "FEW_PAIRS", -1)
            cells = Cells.build(p, 5.0)
        got[rings] = [kth_distance(cells, q, k, plan=plan) for k in (1, 3, 40)] + [
            count_within(cells, q, r, 5, plan=plan) for r in (30.0, 80.0)] + [
            count_within(cells, q, np.full(len(q), 80.0), 50, strict=False, plan=plan)]
    for k, got_k in zip((1, 3, 40), got[False][:3], strict=True):
        want = tree.query(q[:, :2] if plan else q, k=k)[0]
        assert np.array_equal(got_k, want[:, -1] if want.ndim == 2 else want)
    for r, got_r in zip((30.0, 80.0), got[False][3:5], strict=True):
        d = tree.query(q[:, :2] if plan else q, k=5, distance_upper_bound=r)[0]
        assert np.array_equal(got_r, np.isfinite(d).sum(axis=1))
    for a, b in zip(got[False], got[True], strict=True):
        assert np.array_equal(a, b)
    assert kth_distance(cells, q, 41, plan=plan).tolist() == [np.inf] * len(q)


def test_edges():
    p = _cloud(30, 3.0, 5)
    cells = Cells.build(p, 0.5)
    assert count_within(cells, p[:3], np.inf, 10**6).tolist() == [30, 30, 30]
    assert np.isinf(kth_distance(cells, p[:3], 31)).all()
    empty = Cells.build(np.zeros((0, 3)), 0.5)
    assert count_within(empty, p[:2], 1.0, 5).tolist() == [0, 0]
    assert np.isinf(kth_distance(empty, p[:2], 1)).all()
    one = Cells.build(p[:1], 0.5)
    assert kth_distance(one, p[:1], 1).tolist() == [0.0]


@pytest.mark.parametrize("extent", [8.0, 400.0])
def test_nearest_within_is_the_trees_with_ties_to_the_first_row(extent):
    p = _cloud(3000, extent, 6)[:, :2]
    cells = Cells.build(p - p.min(axis=0), 0.3)
    rng = np.random.default_rng(7)
    q = p[rng.integers(0, len(p), 500)] - p.min(axis=0) + np.round(rng.normal(0, 0.2, (500, 2)), 3)
    reach, tie = 0.6, 1e-9
    d, row = nearest_within(cells, q, reach, tie)
    want_d, _ = cKDTree(p - p.min(axis=0)).query(q, k=1, distance_upper_bound=reach)
    assert np.array_equal(d, want_d)
    found = np.isfinite(d)
    assert (row[~found] == -1).all()
    # the row given is the first of those as near (to ``tie``)
    dist = np.hypot(*(q[found, None, :] - (p - p.min(axis=0))[None, :, :]).transpose(2, 0, 1))
    first = np.argmax(dist - d[found, None] < tie, axis=1)
    assert np.array_equal(row[found], first)
    # a repeated sounding: the first of its copies
    copies = (p - p.min(axis=0))[len(p) // 2:len(p) // 2 + 3]
    assert nearest_within(cells, copies, reach, tie)[1].tolist() == [0, 1, 2]


def test_searches_split_among_threads_give_the_same_answers(monkeypatch):
    p = _cloud(4000, 30.0, 8)
    cells = Cells.build(p, 0.5)
    one = (count_within(cells, p, 0.6, 9), kth_distance(cells, p, 4), nearest_within(cells, p + 0.01, 0.6))
    monkeypatch.setattr(neighbours, "SPLIT_FROM", 10)
    monkeypatch.setenv("OMP_NUM_THREADS", "3")
    monkeypatch.setattr(neighbours.os, "sched_getaffinity", lambda pid: {0, 1, 2}, raising=False)
    assert neighbours.threads() == 3
    split = (count_within(cells, p, 0.6, 9), kth_distance(cells, p, 4), nearest_within(cells, p + 0.01, 0.6))
    assert np.array_equal(one[0], split[0]) and np.array_equal(one[1], split[1])
    assert np.array_equal(one[2][0], split[2][0]) and np.array_equal(one[2][1], split[2][1])
    monkeypatch.setenv("OMP_NUM_THREADS", "1")  # what Dask's workers set
    assert neighbours.threads() == 1


def _numpy_percentile(ks: np.ndarray, zs: np.ndarray, q: float, size: int) -> np.ndarray:
    """The per-cell percentile of values sorted by (cell, value), in NumPy (the reference)."""
    out = np.full(size, np.nan)
    starts = np.flatnonzero(np.r_[True, ks[1:] != ks[:-1]])
    counts = np.diff(np.r_[starts, len(ks)])
    out[ks[starts]] = zs[starts + np.floor(q / 100.0 * (counts - 1)).astype(np.int64)]
    return out


def test_cell_segments_and_their_percentiles_are_numpys():
    rng = np.random.default_rng(9)
    key = rng.integers(0, 300, 20_000)
    z = np.round(rng.normal(-20.0, 0.8, len(key)), 3)
    starts, zz = cell_segments(key, z)
    order = np.lexsort((z, key))
    ks = key[order]
    assert np.allclose(zz, z[order], atol=5e-4)
    assert np.array_equal(np.diff(starts), np.bincount(key, minlength=300))
    median = segment_percentile(starts, zz, 50.0)
    assert np.array_equal(median, _numpy_percentile(ks, zz, 50.0, 300))
    padded = np.r_[median, np.full(10, np.nan)]  # cells past the last sounding's are empty
    assert np.array_equal(cell_percentile(key, z, 50.0, 310), padded, equal_nan=True)
    sane = zz >= median[ks] - 1.0
    want = _numpy_percentile(ks[sane], zz[sane], 10.0, 300)
    assert np.array_equal(segment_percentile(starts, zz, 10.0, median, below=1.0), want)
    ref = median + 0.2
    near = np.abs(zz - ref[ks]) <= 0.3
    want = _numpy_percentile(ks[near], zz[near], 50.0, 300)
    assert np.array_equal(segment_percentile(starts, zz, 50.0, ref, band=0.3), want, equal_nan=True)


def test_floor_cells_is_numpys_floor():
    rng = np.random.default_rng(10)
    p = np.round(rng.uniform(500_000.0, 500_050.0, (50_000, 3)), 3)  # millimetres on cell edges
    cases = ((0.0, 0.0, 10.0, 1e-6), (500_000.0, 500_000.0, 2.0, 0.0), (123.4, 5.6, 1 / 0.3, 0.0))
    for x0, y0, inv, edge in cases:
        i, j = floor_cells(p, x0, y0, inv, edge, (7, -3))
        assert np.array_equal(i, np.floor((p[:, 0] - x0) * inv + edge).astype(np.int64) - 7)
        assert np.array_equal(j, np.floor((p[:, 1] - y0) * inv + edge).astype(np.int64) + 3)
