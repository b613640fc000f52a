"""What a reef plan says: each candidate layout's predicted coverage of the units (soundings on
each, found in its place), feature detection, the spread of the reefs' heights and centres,
and time on site; ``plan.json`` is :meth:`ReefPlanResult.to_dict`, read back by
:meth:`ReefPlanResult.from_dict`."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from ..outputs import to_jsonable
from .layouts import Layout, PlanLine
from .reef_trial import PlannedUnit
from .results import null_as_nan

__all__ = ["ReefPlanResult", "ReefPrediction", "UnitPrediction"]


@dataclass(frozen=True)
class UnitPrediction:
    """One unit over a layout's surveys: the share in which a reef was found in its place, the
    fewest and the mean soundings on it, and the RMS of its height and centre errors (m)."""

    id: str
    found: float
    min_soundings: int
    mean_soundings: float
    height_error_rms: float
    centre_error_rms: float

    def to_dict(self) -> dict[str, Any]:
        return {"id": self.id, "found": self.found, "min_soundings": self.min_soundings,
                "mean_soundings": self.mean_soundings, "height_error_rms": self.height_error_rms,
                "centre_error_rms": self.centre_error_rms}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> UnitPrediction:
        return cls(str(d["id"]), float(d["found"]), int(d["min_soundings"]), float(d["mean_soundings"]),
                   null_as_nan(d["height_error_rms"]), null_as_nan(d["centre_error_rms"]))


@dataclass(frozen=True)
class ReefPrediction:
    """One candidate layout: its lines, time on site (s), each unit's prediction, the share of
    cubes of the S-44 order's size detected (None: no feature detection asked), the predicted
    1-sigma of a reef's height and of its centre (the RMS of the errors over every unit and
    survey), whether it meets the targets and the surveys it rests on."""

    layout: Layout
    time_on_site_s: float
    units: tuple[UnitPrediction, ...]
    cubes_detected: float | None
    height_sigma: float
    centre_sigma: float
    meets_target: bool
    surveys: int

    @property
    def min_soundings(self) -> int:
        """The fewest soundings any unit got in any survey."""
        return min((u.min_soundings for u in self.units), default=0)

    @property
    def found(self) -> float:
        """The share of units found in their place, over every survey."""
        return sum(u.found for u in self.units) / len(self.units) if self.units else 0.0

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.layout.name, "description": self.layout.description,
                "time_on_site_s": self.time_on_site_s, "meets_target": self.meets_target,
                "surveys": self.surveys, "found": self.found, "min_soundings": self.min_soundings,
                "cubes_detected": self.cubes_detected, "height_sigma": self.height_sigma,
                "centre_sigma": self.centre_sigma,
                "lines": [{"line": k + 1, **ln.to_dict()} for k, ln in enumerate(self.layout.lines)],
                "units": [u.to_dict() for u in self.units]}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> ReefPrediction:
        layout = Layout(d["name"], d["description"], tuple(PlanLine.from_dict(ln) for ln in d["lines"]))
        cubes = d.get("cubes_detected")
        return cls(layout, float(d["time_on_site_s"]), tuple(UnitPrediction.from_dict(u) for u in d["units"]),
                   None if cubes is None else float(cubes), null_as_nan(d["height_sigma"]),
                   null_as_nan(d["centre_sigma"]),
                   bool(d["meets_target"]), int(d["surveys"]))


@dataclass(frozen=True)
class ReefPlanResult:
    """A survey plan over a reef plan: its units, every candidate evaluated (fastest first),
    the one chosen, the targets (soundings on every unit, the S-44 order), the options and
    reading in ``parameters``."""

    units: tuple[PlannedUnit, ...]
    predictions: tuple[ReefPrediction, ...]
    chosen: str | None
    min_soundings: int
    s44_order: str
    parameters: dict[str, Any] = field(default_factory=dict)
    warnings: tuple[str, ...] = ()

    @property
    def best(self) -> ReefPrediction | None:
        """The chosen layout's prediction."""
        return next((p for p in self.predictions if p.layout.name == self.chosen), None)

    @property
    def speed_kn(self) -> float | None:
        """The speed (kn) the lines are sailed at."""
        speed = self.parameters.get("speed")
        return float(speed) if speed is not None else None

    def to_dict(self) -> dict[str, Any]:
        """``plan.json`` (``kind`` ``reef-plan``): the chosen layout's ``lines``, ``units``
        and ``time_on_site_s`` at the top level, every candidate under ``layouts``, the others
        under ``runner_up``."""
        best = self.best
        top: dict[str, Any] = {"kind": "reef-plan", "min_soundings": self.min_soundings,
                               "s44_order": self.s44_order, "chosen": self.chosen,
                               "meets_target": best.meets_target if best else False}
        if best is not None:
            b = best.to_dict()
            top.update({k: b[k] for k in ("time_on_site_s", "lines", "units", "found", "cubes_detected",
                                          "height_sigma", "centre_sigma")})
            top["min_soundings_reached"] = b["min_soundings"]
        top["runner_up"] = [{k: v for k, v in p.to_dict().items() if k not in ("lines", "units")}
                            for p in self.predictions if p.layout.name != self.chosen]
        top["plan"] = [{"id": u.id, "x": u.x, "y": u.y, "bearing_deg": u.bearing_deg, "kind": u.kind,
                        "reach": u.reach} for u in self.units]
        top["layouts"] = [p.to_dict() for p in self.predictions]
        top["warnings"] = list(self.warnings)
        top["parameters"] = self.parameters
        return to_jsonable(top)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> ReefPlanResult:
        units = tuple(PlannedUnit(str(u["id"]), float(u["x"]), float(u["y"]),
                                  None if u.get("bearing_deg") is None else float(u["bearing_deg"]),
                                  str(u["kind"]), float(u["reach"])) for u in d["plan"])
        return cls(units, tuple(ReefPrediction.from_dict(p) for p in d["layouts"]), d.get("chosen"),
                   int(d["min_soundings"]), str(d["s44_order"]), dict(d.get("parameters") or {}),
                   tuple(d.get("warnings") or ()))
