"""What a comparison of two surveys returns: the registration, each object's change with
its 95 % level of detection, and what the comparison read; ``to_dict()`` is
``change.json`` and ``from_dict()`` reads it back."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from ..outputs import to_jsonable
from .register import Registration

__all__ = ["ObjectChange", "ChangeResult", "MEASURES", "STATUSES"]

#: The object's statuses.
STATUSES = ("unchanged", "changed", "removed", "new")

#: Each measured change: (field, unit, what it is). Every one has ``<field>_lod95`` beside it.
MEASURES: tuple[tuple[str, str, str], ...] = (
    ("dx", "m", "plan displacement east"),
    ("dy", "m", "plan displacement north"),
    ("displacement", "m", "plan displacement"),
    ("rotation_deg", "deg", "turn about the vertical (clockwise), within the design's symmetry"),
    ("settlement", "m", "the top went down by (its plane's highest point in the levelled soundings, "
                        "else the least depth; registered; positive down)"),
    ("height_change", "m", "exposed height (top over the seabed round it) after minus before"),
    ("tilt_change_deg", "deg", "the top plane's tilt after minus before"),
    ("scour_depth", "m", "the seabed round the unit went down by (deepest ring)"),
    ("scour_radius", "m", "from the unit's centre to where the scour is half its depth"),
    ("scour_volume", "m3", "the seabed lost round the unit"),
)


@dataclass(frozen=True)
class ObjectChange:
    """One object followed from the before survey to the after survey.

    Attributes
    ----------
    id_before, id_after : int or None
        Its id in each survey's result (None: not there).
    status : {"unchanged", "changed", "removed", "new"}
    x_before, y_before, x_after, y_after : float
        Its centre in each survey, both in the before survey's frame (NaN: not there).
    values : dict
        Each measure of :data:`MEASURES` with its ``_lod95``, and the levels read
        (``height_before``, ``height_after``, ``tilt_before``, ``tilt_after``,
        ``overturned_before``, ``overturned_after``, ``design``).
    detected : tuple of str
        The measures whose change exceeds its level of detection (and ``overturned`` when
        the unit came to rest otherwise); empty: no detectable change.
    notes : tuple of str
        Why a measure could not be made.
    """

    id_before: int | None
    id_after: int | None
    status: str
    x_before: float = math.nan
    y_before: float = math.nan
    x_after: float = math.nan
    y_after: float = math.nan
    values: dict[str, Any] = field(default_factory=dict)
    detected: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        return to_jsonable({"id_before": self.id_before, "id_after": self.id_after, "status": self.status,
                            "x_before": self.x_before, "y_before": self.y_before, "x_after": self.x_after,
                            "y_after": self.y_after, **self.values, "detected": list(self.detected),
                            "notes": list(self.notes)})

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> ObjectChange:
        fixed = ("id_before", "id_after", "status", "x_before", "y_before", "x_after", "y_after")
        nan = {k: math.nan if d.get(k) is None else d[k] for k in fixed[3:]}
        return cls(d.get("id_before"), d.get("id_after"), d["status"], **nan,
                   values={k: v for k, v in d.items() if k not in fixed + ("detected", "notes")},
                   detected=tuple(d.get("detected", ())), notes=tuple(d.get("notes", ())))


@dataclass(frozen=True)
class ChangeResult:
    """Two surveys compared.

    Attributes
    ----------
    kind : {"reefs"}
        What was compared.
    registration : Registration
        The after survey's offset from the before survey, removed before every change.
    objects : tuple of ObjectChange
    parameters : dict
        The options, the two results read and their vertical references.
    warnings : tuple of str
    difference : Any
        The registered difference map (:class:`~mbinspect.change.grid.Grid`, after minus
        before), not serialised.
    """

    kind: str
    registration: Registration
    objects: tuple[ObjectChange, ...]
    parameters: dict[str, Any]
    warnings: tuple[str, ...] = ()
    difference: Any = field(default=None, repr=False, compare=False)

    def counts(self) -> dict[str, int]:
        """How many objects have each status."""
        return {s: sum(o.status == s for o in self.objects) for s in STATUSES}

    def to_dict(self) -> dict[str, Any]:
        return {"change": self.kind, "registration": self.registration.to_dict(), "counts": self.counts(),
                "objects": [o.to_dict() for o in self.objects], "parameters": to_jsonable(self.parameters),
                "warnings": list(self.warnings)}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> ChangeResult:
        return cls(d["change"], Registration.from_dict(d["registration"]),
                   tuple(ObjectChange.from_dict(o) for o in d["objects"]), dict(d.get("parameters", {})),
                   tuple(d.get("warnings", ())))
