"""What a plan says: each candidate layout's predicted spacings, levels, unseen sides and time
on site, and the one chosen; ``plan.json`` is :meth:`PlanResult.to_dict`, read back by
:meth:`PlanResult.from_dict`."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from ..outputs import to_jsonable
from .layouts import KNOT, Layout, PlanLine
from .predict import SECTORS, DesignPile

__all__ = ["PlanResult", "Prediction", "PredictedSpacing", "SCATTER_FLOOR"]


def null_as_nan(value: Any) -> float:
    """A number read back from a plan's JSON: ``null`` (a NaN written) as NaN."""
    return math.nan if value is None else float(value)


@dataclass(frozen=True)
class PredictedSpacing:
    """One spacing's prediction: the design distance, the predicted 1-sigma (m), the 1-sigma
    the runs reported and the RMS of their errors against the truth, over ``n`` surveys."""

    a: int
    b: int
    design: float
    sigma: float
    reported_sigma: float
    error_rms: float
    n: int

    def to_dict(self) -> dict[str, Any]:
        return {"a": self.a, "b": self.b, "design": self.design, "sigma": self.sigma,
                "reported_sigma": self.reported_sigma, "error_rms": self.error_rms, "surveys": self.n}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> PredictedSpacing:
        return cls(int(d["a"]), int(d["b"]), float(d["design"]), null_as_nan(d["sigma"]),
                   null_as_nan(d["reported_sigma"]), null_as_nan(d["error_rms"]), int(d["surveys"]))


#: The least relative scatter of a prediction from one survey: the scatter of a layout's worst
#: predicted 1-sigma between independent sets of three surveys was 12 % and 28 % (two '#'
#: layouts at 2 kn, eight sets each; ``benchmarks/RESULTS.md``), 0.21 and 0.49 per survey.
SCATTER_FLOOR = 0.2


@dataclass(frozen=True)
class Prediction:
    """One candidate layout: its lines, time on site (s), predicted spacings, each top level's
    predicted 1-sigma, the sides of each pile no beam reached (sector names), the share of
    surveys in which each pile was not found, whether it meets the target, the surveys it
    rests on and the calibration: the factor from the 1-sigma the runs reported to the spread
    of their errors."""

    layout: Layout
    time_on_site_s: float
    spacings: tuple[PredictedSpacing, ...]
    tops: tuple[tuple[int, float], ...]
    unseen: tuple[tuple[int, tuple[str, ...]], ...]
    missed: tuple[tuple[int, float], ...]
    meets_target: bool
    surveys: int
    calibration: float = 1.0
    scatter: float = math.nan

    @property
    def worst_sigma(self) -> float:
        """The largest predicted spacing 1-sigma (inf when a spacing was never measured)."""
        return max((s.sigma for s in self.spacings), default=math.inf)

    @property
    def sigma_error(self) -> float:
        """The relative 1-sigma of :attr:`worst_sigma` as an estimate from ``surveys`` surveys:
        the ``scatter`` its surveys show (a delete-one jackknife over them), at least
        :data:`SCATTER_FLOOR` / sqrt(n); 1/sqrt(2n), the bound of an RMS of n errors, where
        no scatter is known (one survey, or a plan written before it was kept)."""
        n = max(self.surveys, 1)
        if not math.isfinite(self.scatter):
            return 1.0 / math.sqrt(2.0 * n)
        return max(self.scatter, SCATTER_FLOOR / math.sqrt(n))

    def upper(self, sigma: float) -> float:
        """A 1-sigma these surveys predicted, at its estimate's upper 1-sigma bound."""
        return sigma * (1.0 + self.sigma_error)

    @property
    def worst_upper(self) -> float:
        """:attr:`worst_sigma` at its estimate's upper 1-sigma bound: what the target is held to."""
        return self.upper(self.worst_sigma)

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.layout.name, "description": self.layout.description,
                "time_on_site_s": self.time_on_site_s, "meets_target": self.meets_target,
                "worst_sigma": self.worst_sigma, "worst_sigma_upper": self.worst_upper,
                "surveys": self.surveys, "calibration": self.calibration,
                "scatter": self.scatter, "sigma_error": self.sigma_error,
                "speed_kn": self.layout.speed / KNOT if self.layout.speed else None,
                "lines": [{"line": k + 1, **ln.to_dict(),
                           "over_tops": bool(self.layout.over_tops and self.layout.over_tops[k])}
                          for k, ln in enumerate(self.layout.lines)],
                "predicted": [s.to_dict() for s in self.spacings],
                "levels": [{"id": i, "sigma": s} for i, s in self.tops],
                "unseen_sides": [{"id": i, "sectors": list(s)} for i, s in self.unseen],
                "missed": [{"id": i, "share": s} for i, s in self.missed]}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Prediction:
        speed = d.get("speed_kn")
        flags = tuple(bool(ln.get("over_tops", False)) for ln in d["lines"])
        layout = Layout(d["name"], d["description"], tuple(PlanLine.from_dict(ln) for ln in d["lines"]),
                        float(speed) * KNOT if speed else None, flags if any(flags) else ())
        return cls(layout, float(d["time_on_site_s"]),
                   tuple(PredictedSpacing.from_dict(s) for s in d["predicted"]),
                   tuple((int(t["id"]), null_as_nan(t["sigma"])) for t in d["levels"]),
                   tuple((int(u["id"]), tuple(u["sectors"])) for u in d["unseen_sides"]),
                   tuple((int(m["id"]), float(m["share"])) for m in d["missed"]), bool(d["meets_target"]),
                   int(d["surveys"]), float(d.get("calibration", 1.0)), null_as_nan(d.get("scatter")))


@dataclass(frozen=True)
class PlanResult:
    """A survey plan: the design's piles, every candidate evaluated (fastest first), the one
    chosen (``None`` when none was evaluated), the options and reading in ``parameters``."""

    piles: tuple[DesignPile, ...]
    predictions: tuple[Prediction, ...]
    chosen: str | None
    target_sigma: float
    parameters: dict[str, Any] = field(default_factory=dict)
    warnings: tuple[str, ...] = ()

    @property
    def best(self) -> Prediction | None:
        """The chosen layout's prediction."""
        return next((p for p in self.predictions if p.layout.name == self.chosen), None)

    @property
    def speed_kn(self) -> float | None:
        """The speed (kn) the chosen layout's lines are sailed at."""
        best = self.best
        if best is not None and best.layout.speed:
            return best.layout.speed / KNOT
        speed = self.parameters.get("speed")
        return float(speed) if speed is not None else None

    def to_dict(self) -> dict[str, Any]:
        """``plan.json``: the chosen layout's ``lines``, ``predicted`` spacings (``a``, ``b``,
        ``sigma``) and ``time_on_site_s`` at the top level, every candidate under ``layouts``
        and the others, fastest first, under ``runner_up``."""
        best = self.best
        top: dict[str, Any] = {"kind": "plan", "target_sigma": self.target_sigma, "chosen": self.chosen,
                               "meets_target": best.meets_target if best else False}
        if best is not None:
            b = best.to_dict()
            top.update(time_on_site_s=b["time_on_site_s"], speed_kn=self.speed_kn, lines=b["lines"],
                       predicted=b["predicted"],
                       levels=b["levels"], unseen_sides=b["unseen_sides"])
        top["runner_up"] = [{k: v for k, v in p.to_dict().items() if k in
                             ("name", "description", "time_on_site_s", "meets_target", "worst_sigma")}
                            for p in self.predictions if p.layout.name != self.chosen]
        top["design"] = [{"id": p.id, "x": p.x, "y": p.y, "top": p.top, "group": p.group,
                          "tilt_deg": p.tilt_deg, "tilt_azimuth_deg": p.tilt_azimuth_deg} for p in self.piles]
        top["layouts"] = [p.to_dict() for p in self.predictions]
        top["sectors"] = list(SECTORS)
        top["warnings"] = list(self.warnings)
        top["parameters"] = self.parameters
        return to_jsonable(top)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> PlanResult:
        piles = tuple(DesignPile(int(p["id"]), float(p["x"]), float(p["y"]), float(p["top"]), int(p["group"]),
                                 float(p.get("tilt_deg", 0.0)), float(p.get("tilt_azimuth_deg", 0.0)))
                      for p in d["design"])
        return cls(piles, tuple(Prediction.from_dict(p) for p in d["layouts"]), d.get("chosen"),
                   float(d["target_sigma"]), dict(d.get("parameters") or {}), tuple(d.get("warnings") or ()))
