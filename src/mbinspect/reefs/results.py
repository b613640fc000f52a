"""What the reef pipeline returns: one record per reef and the whole result."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..evaluate import Evaluation
from ..least_depth import least_of
from ..outputs import Recorded, record_from, to_jsonable
from .terrain import TerrainMask

__all__ = ["Reef", "OtherObject", "ReefResult"]


@dataclass(frozen=True)
class Reef:
    """One reef's measures; ``to_dict()`` is a row of ``reefs.json``."""

    id: int
    x: float
    y: float
    z_seabed: float
    z_top: float
    height: float
    area: float
    length: float
    width: float
    orientation_deg: float
    volume: float
    envelope_volume: float
    n_points: int
    group: int = 0
    outline: tuple[tuple[float, float], ...] = field(default=(), repr=False)
    design: str = ""
    design_scale: float = math.nan
    design_bearing_deg: float = math.nan
    design_misfit: float = math.nan
    sources: tuple[dict[str, Any], ...] = field(default=(), repr=False)
    least: dict[str, Any] = field(default_factory=dict)
    buried_share: float = math.nan
    plan: dict[str, Any] = field(default_factory=dict)
    top_tilt_deg: float = math.nan
    top_tilt_sigma_deg: float = math.nan
    resting: str = ""
    overturned: bool | None = None
    resting_misfit: float = math.nan
    resting_note: str = ""
    beam_footprint: float = math.nan

    def to_dict(self) -> dict[str, Any]:
        """One row of ``reefs.json`` (``outline``: the footprint polygon, m; the least depth's
        ``least_depth*`` keys, :meth:`~mbinspect.least_depth.LeastDepth.fields`; how it rests,
        :mod:`~mbinspect.reefs.orient`; ``beam_footprint``: told the beam, the width (m) of the
        beam's footprint where the reef was heard, its soundings' median slant range times the
        beam width, else NaN)."""
        d = {k: getattr(self, k) for k in ("id", "x", "y", "z_seabed", "z_top", "height", "area",
                                             "length", "width", "orientation_deg", "volume",
                                             "envelope_volume", "n_points", "group", "design",
                                             "design_scale", "design_bearing_deg", "design_misfit",
                                             "buried_share", *REST_KEYS, "beam_footprint")}
        d.update(self.least)
        d.update(self.plan)
        d["outline"] = [list(v) for v in self.outline]
        d["sources"] = list(self.sources)
        return to_jsonable(d)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Reef:
        """The reef of a ``reefs.json`` row (:meth:`to_dict`'s inverse)."""
        return record_from(cls, d, least=least_of(d), plan={k: d[k] for k in PLAN_KEYS if k in d})


#: The keys of how a reef rests (:func:`~mbinspect.reefs.orient.with_rest`).
REST_KEYS = ("top_tilt_deg", "top_tilt_sigma_deg", "resting", "overturned", "resting_misfit",
             "resting_note")

#: The keys of a reef's placement against the plan (:mod:`mbinspect.reefs.plan`).
PLAN_KEYS = ("plan_id", "plan_dx", "plan_dy", "plan_offset", "plan_offset_sigma", "placement",
             "placement_note", "bearing_error_deg", "bearing_error_sigma_deg", "in_permit")


@dataclass(frozen=True)
class OtherObject:
    """An object on the seabed that is not taken for a reef, and why.

    Attributes
    ----------
    x, y : float
        Its centre (m).
    height, area : float
        Above the seabed (m) and its footprint (m²).
    z_top : float
        Its highest sounding (m).
    n_points : int
    reason : str
    """

    x: float
    y: float
    height: float
    area: float
    z_top: float
    n_points: int
    reason: str
    least: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """One row of ``others`` in ``reefs.json``, with its least depth."""
        return to_jsonable({"x": self.x, "y": self.y, "height": self.height, "area": self.area,
                            "z_top": self.z_top, "n_points": self.n_points, "reason": self.reason,
                            **self.least})

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> OtherObject:
        """The record of an ``others`` row."""
        return record_from(cls, d, least=least_of(d))



@dataclass(frozen=True, eq=False)
class ReefResult:
    """Everything :func:`~mbinspect.reefs.extract_reefs` measured; ``to_dict()`` is ``reefs.json``.

    Attributes
    ----------
    reefs : tuple of Reef
        In reading order (north to south, west to east), ids from 1.
    groups, others : tuple of dict
        The groups of reefs, and the objects too small to be reefs.
    seabed, filters : dict
        The seabed model used and its ground residual; what each filter removed.
    evaluation : Evaluation or None
        The score against the reference, when one was given.
    parameters : dict
        The options (``ReefOptions.to_dict()``), the input and the software version; the
        command line adds the input file's size and sha256 and the command.
    warnings : tuple of str
    region, surface
        The excluded terrain and the seabed surface (for figures).
    footprint : dict
        ``reef_area_used``: the single-reef area the splitting used (m²).
    reference_xy : ndarray (R, 2) or None
        The reference positions scored against.
    plan_missing : tuple of dict or None
        With a plan (:func:`~mbinspect.reefs.plan.place_reefs`): the planned units no reef
        was matched to.
    """

    reefs: tuple[Reef, ...]
    groups: tuple[dict[str, Any], ...]
    others: tuple[OtherObject, ...]
    seabed: dict[str, Any]
    filters: dict[str, Any]
    evaluation: Evaluation | None
    parameters: dict[str, Any]
    warnings: tuple[str, ...] = ()
    region: TerrainMask | Recorded | None = field(default=None, repr=False)
    surface: Any = field(default=None, repr=False)
    footprint: dict[str, Any] = field(default_factory=dict)
    reference_xy: np.ndarray | None = field(default=None, repr=False)
    plan_missing: tuple[dict[str, Any], ...] | None = None

    def to_dict(self) -> dict[str, Any]:
        """The result as JSON-ready dicts and lists (``reefs.json``)."""
        ev = None
        if self.evaluation is not None:
            ev = self.evaluation.to_dict()
            ids = [r.id for r in self.reefs]
            for m in ev["matches"]:
                m["reef"] = ids[m.pop("detection")]
            ev["unmatched_reefs"] = [ids[i] for i in ev.pop("unmatched_detections")]
            ev["reference_xy"] = self.reference_xy
        return to_jsonable({
            "reefs": [r.to_dict() for r in self.reefs],
            "groups": list(self.groups), "others": [o.to_dict() for o in self.others],
            "seabed": self.seabed, "filters": self.filters, "evaluation": ev,
            "parameters": self.parameters, "warnings": list(self.warnings),
            "region": self.region.to_dict() if self.region is not None else None,
            "footprint": self.footprint,
            **({"plan_missing": list(self.plan_missing)} if self.plan_missing is not None else {}),
        })

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> ReefResult:
        """The result of a ``reefs.json`` (:func:`mbinspect.results.read_result`): ``to_dict()``
        of what it returns is ``d``; the soundings and the seabed surface behind the answer
        are not in the file (the terrain mask's summary is kept)."""
        reefs = tuple(Reef.from_dict(r) for r in d["reefs"])
        ev, ref_xy = d.get("evaluation"), None
        evaluation = None
        if ev is not None:
            index = {r.id: k for k, r in enumerate(reefs)}
            refs = [m["reference"] for m in ev["matches"]] + list(ev["unmatched_references"])
            where = {ref: j for j, ref in enumerate(refs)}
            evaluation = Evaluation(ev["tp"], ev["fp"], ev["fn"], ev["tolerance"],
                                    tuple((index[m["reef"]], where[m["reference"]], m["distance"])
                                          for m in ev["matches"]),
                                    tuple(index[i] for i in ev["unmatched_reefs"]),
                                    tuple(where[ref] for ref in ev["unmatched_references"]), tuple(refs))
            ref_xy = None if ev.get("reference_xy") is None else np.asarray(ev["reference_xy"], float)
        region = d.get("region")
        others = tuple(OtherObject.from_dict(o) for o in d.get("others", []))
        return cls(reefs, tuple(d.get("groups", [])), others,
                   dict(d.get("seabed") or {}), dict(d.get("filters") or {}), evaluation,
                   dict(d.get("parameters", {})), tuple(d.get("warnings", [])),
                   None if region is None else Recorded(region), None, dict(d.get("footprint") or {}), ref_xy,
                   None if d.get("plan_missing") is None else tuple(d["plan_missing"]))
