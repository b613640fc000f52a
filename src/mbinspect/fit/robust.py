"""One robust estimation loop (RANSAC / MSAC) that serves every model."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

import numpy as np

from ..errors import ParameterError

__all__ = ["RobustResult", "msac", "ransac_trials", "clustered_cov"]

M = TypeVar("M")


def ransac_trials(inlier_ratio: float, sample_size: int, confidence: float = 0.99) -> int:
    """Trials N so that an all-inlier sample is drawn with probability ``confidence``.

    ``N = ln(1 - q) / ln(1 - P**K)`` (the reef paper's eq. 4) with P the inlier ratio
    and K the sample size.

    Parameters
    ----------
    inlier_ratio : float
        P, 0 to 1.
    sample_size : int
        K.
    confidence : float
        q, 0 to 1.

    Returns
    -------
    int

    Examples
    --------
    >>> ransac_trials(0.5, 3, 0.99)
    35
    """
    p = min(max(inlier_ratio, 1e-9), 1.0)
    if p >= 1.0:
        return 1
    denom = math.log(max(1.0 - p**sample_size, 1e-300))
    if denom == 0.0:
        return 10**9
    return int(math.ceil(math.log(1.0 - confidence) / denom))


# ---------------------------------------------------------------------------- models


@dataclass(frozen=True)
class RobustResult(Generic[M]):
    """Result of :func:`msac`: the model, its inlier mask, the score and trials run."""

    model: M | None
    inliers: np.ndarray
    score: float
    trials: int
    inlier_ratio: float


def msac(
    data: np.ndarray,
    estimate: Callable[[np.ndarray], M | Sequence[M] | None],
    residuals: Callable[[M, np.ndarray], np.ndarray],
    sample_size: int,
    threshold: float,
    *,
    loss: str = "msac",
    max_trials: int = 2000,
    min_trials: int = 20,
    confidence: float = 0.99,
    refine: Callable[[np.ndarray, M], M | None] | None = None,
    seed: int | np.random.Generator | None = 0,
) -> RobustResult[M]:
    """One robust loop for every model: RANSAC or MSAC scoring, adaptive trial count.

    Parameters
    ----------
    data : ndarray, shape (N, D)
        Rows are observations (points, or points with normals).
    estimate : callable
        ``estimate(sample_rows)`` gives a model, a list of candidate models, or None for
        a degenerate sample.
    residuals : callable
        ``residuals(model, data)`` gives orthogonal distances, shape (N,).
    sample_size : int
        Rows per minimal sample.
    threshold : float
        Inlier distance (same unit as the residuals).
    loss : {"msac", "ransac"}
        MSAC scores inliers by their squared residual (truncated at ``threshold``);
        RANSAC counts them.
    max_trials, min_trials, confidence : int, int, float
        The trial count adapts as ``ln(1 - confidence) / ln(1 - P**K)`` with the best
        inlier ratio P seen so far, between the two bounds.
    refine : callable, optional
        ``refine(inlier_rows, model)`` re-estimates the best model from all its inliers
        (local optimisation), repeated while the score improves.
    seed : int or Generator
        Randomness; the same seed gives the same result.
    """
    if loss not in ("msac", "ransac"):
        raise ParameterError(f"loss: {loss!r} is not 'msac' or 'ransac'")
    if threshold <= 0:
        raise ParameterError(f"threshold: {threshold} must be positive")
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    n = len(data)
    empty: RobustResult[M] = RobustResult(None, np.zeros(n, dtype=bool), math.inf, 0, 0.0)
    if n < sample_size:
        return empty
    t2 = threshold * threshold

    def score_of(model: M) -> tuple[float, np.ndarray]:
        """The loss of ``model`` (lower is better) and its inlier mask."""
        r = residuals(model, data)
        r2 = r * r
        inl = r2 <= t2
        if loss == "msac":
            return float(np.minimum(r2, t2).sum()), inl
        return float(n - inl.sum()), inl

    best: M | None = None
    best_score, best_inl = math.inf, np.zeros(n, dtype=bool)
    needed, trial = max_trials, 0
    while trial < min(needed, max_trials):
        trial += 1
        idx = rng.choice(n, sample_size, replace=False)
        models = estimate(data[idx])
        if models is None:
            continue
        candidates: list[M] = list(models) if isinstance(models, (list, tuple)) else [models]  # type: ignore[list-item]
        for model in candidates:
            s, inl = score_of(model)
            if s < best_score:
                best, best_score, best_inl = model, s, inl
                ratio = inl.sum() / n
                needed = max(min_trials, ransac_trials(ratio, sample_size, confidence))
    if best is not None and refine is not None and best_inl.sum() >= sample_size:
        best, best_score, best_inl = _local_optimisation(data, best, best_score, best_inl, refine, score_of)
    if best is None:
        return RobustResult(None, best_inl, math.inf, trial, 0.0)
    return RobustResult(best, best_inl, best_score, trial, float(best_inl.sum()) / n)


def _local_optimisation(data: np.ndarray, best: Any, score: float, inliers: np.ndarray,
                        refine: Callable[[np.ndarray, Any], Any],
                        score_of: Callable[[Any], tuple[float, np.ndarray]]) -> tuple[Any, float, np.ndarray]:
    """The best model re-estimated from all its inliers, up to three times, while the
    score improves."""
    for _ in range(3):
        refined = refine(data[inliers], best)
        if refined is None:
            break
        s, inl = score_of(refined)
        if s >= score:
            break
        best, score, inliers = refined, s, inl
    return best, score, inliers


def clustered_cov(dev: np.ndarray, groups: np.ndarray) -> np.ndarray:
    """The cluster-robust covariance of a mean: ``dev`` (N, k), each row's deviation from
    the mean (weighted as the mean weighs it), summed within each group (a ping, a beam),
    the sums' outer products over N².

    Examples
    --------
    >>> clustered_cov(np.array([[1.0], [1.0], [-1.0], [-1.0]]), np.array([0, 0, 1, 1])).tolist()
    [[0.5]]
    """
    d = np.asarray(dev, np.float64).reshape(len(dev), -1)
    _, inv = np.unique(np.asarray(groups), return_inverse=True)
    sums = np.zeros((int(inv.max()) + 1 if len(inv) else 0, d.shape[1]))
    np.add.at(sums, inv, d)
    return sums.T @ sums / max(len(d), 1) ** 2
