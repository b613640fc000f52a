"""Stage 8: the reefs scored against a reference list (one-to-one matching)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from ..evaluate import Evaluation, match_points
from .results import Reef

__all__ = ["score_reefs"]


def score_reefs(reefs: Sequence[Reef], reference: tuple[np.ndarray, tuple[Any, ...]], *,
                tolerance: float) -> tuple[Evaluation, list[str]]:
    """TP/FP/FN of the reefs against reference positions (:func:`~mbinspect.evaluate.match_points`).

    Parameters
    ----------
    reefs : sequence of Reef
    reference : (positions (R, 2), ids)
        Reference reef positions (m) and their ids.
    tolerance : float
        Largest distance of a match (m).

    Returns
    -------
    evaluation : Evaluation
    warnings : list of str
        When reefs and references exist but none match (another coordinate frame?).

    Examples
    --------
    >>> r = Reef(1, 10.0, 20.0, -17.0, -16.0, 1.0, 9.0, 3.0, 3.0, 0.0, 4.0, 9.0, 100)
    >>> ev, _ = score_reefs([r], (np.array([[10.2, 20.1], [40.0, 40.0]]), ("a", "b")), tolerance=1.5)
    >>> ev.tp, ev.fp, ev.fn
    (1, 0, 1)
    """
    ref_xy, ref_ids = reference
    evaluation = match_points(np.array([[r.x, r.y] for r in reefs]).reshape(-1, 2), ref_xy,
                              tolerance=tolerance, reference_ids=ref_ids)
    warnings = []
    if len(reefs) and len(ref_xy) and evaluation.tp == 0:
        warnings.append("no reef matches any reference position within "
                        f"{tolerance} m: is the reference in another coordinate frame?")
    return evaluation, warnings
