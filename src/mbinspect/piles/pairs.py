"""What is measured between piles: a spacing, a level difference, a jacket's frame fit
(rows of ``piles.json``)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..outputs import record_from, to_jsonable

__all__ = ["Spacing", "Level", "FrameFit"]


@dataclass(frozen=True)
class Spacing:
    """The horizontal distance between two pile top centres, its 1-sigma and the design.

    ``verdict`` decides at 95 %: ``pass`` when |deviation| + 1.96 sigma is within the
    tolerance, ``fail`` when |deviation| - 1.96 sigma exceeds it, else ``undecided``;
    ``passed`` is True, False or None accordingly (None also without a design). The JSON
    row adds the distance's 95 % interval, ``low_95`` and ``high_95`` (distance ∓ 1.96 sigma).

    Examples
    --------
    >>> d = Spacing(1, 2, 22.004, 0.005).to_dict()
    >>> round(d["low_95"], 4), round(d["high_95"], 4)
    (21.9942, 22.0138)
    """

    a: int
    b: int
    distance: float
    sigma: float
    design: float | None = None
    deviation: float | None = None
    passed: bool | None = None
    method: str = "intersection"
    verdict: str | None = None
    group: int = 1

    def to_dict(self) -> dict[str, Any]:
        """One row of ``spacings`` in ``piles.json``."""
        return to_jsonable({"group": self.group, "a": self.a, "b": self.b, "distance": self.distance,
                            "sigma": self.sigma, "low_95": self.distance - 1.96 * self.sigma,
                            "high_95": self.distance + 1.96 * self.sigma, "design": self.design,
                            "deviation": self.deviation, "verdict": self.verdict, "pass": self.passed,
                            "method": self.method})

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Spacing:
        """The spacing of a ``spacings`` row (its 95 % bounds follow from it)."""
        return record_from(cls, d, passed=d.get("pass"))


@dataclass(frozen=True)
class FrameFit:
    """A jacket's prefabricated frame (its design template) fitted to the measured centres.

    The best rigid plan transform (rotation, shift) of the design positions of the group
    onto the measured top centres, weighted by their covariances. ``residuals`` holds, per
    pile, the plan miss of the measured centre from the fitted frame (m) and its 1-sigma;
    ``verdict`` says whether the frame fits within ``tolerance`` at 95 %: ``pass`` when every
    miss + 1.96 sigma is within it, ``fail`` when a miss - 1.96 sigma exceeds it, else
    ``undecided``.
    """

    group: int
    rotation_deg: float
    shift_x: float
    shift_y: float
    residuals: tuple[dict[str, Any], ...]
    tolerance: float
    verdict: str

    def to_dict(self) -> dict[str, Any]:
        """The frame fit, JSON-ready."""
        return to_jsonable({"group": self.group, "rotation_deg": self.rotation_deg,
                            "shift_x": self.shift_x, "shift_y": self.shift_y,
                            "residuals": list(self.residuals), "tolerance": self.tolerance,
                            "verdict": self.verdict})

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> FrameFit:
        """The frame fit of a ``frames`` row."""
        return record_from(cls, d)


@dataclass(frozen=True)
class Level:
    """The level difference ``top_z[b] - top_z[a]`` of two piles of a jacket, its 1-sigma,
    and against the design's tops when they are known; ``verdict`` at 95 % against the
    level tolerance; ``lower_bound`` when either top was not sounded."""

    group: int
    a: int
    b: int
    difference: float
    sigma: float
    design: float | None = None
    deviation: float | None = None
    verdict: str | None = None
    lower_bound: bool = False

    def to_dict(self) -> dict[str, Any]:
        """One row of ``levels`` in ``piles.json``."""
        return to_jsonable({"group": self.group, "a": self.a, "b": self.b, "difference": self.difference,
                            "sigma": self.sigma, "design": self.design, "deviation": self.deviation,
                            "verdict": self.verdict, "lower_bound": self.lower_bound})

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Level:
        """The level difference of a ``levels`` row."""
        return record_from(cls, d)
