"""What the pile pipeline returns: one record per pile, spacings, and the whole result.

:class:`PileMeasure` is one pile's measurement within an iteration (what a stage hands to
the next); :class:`PileFit` is a pile as reported, with its flags; :class:`PileResult`
holds everything, and its ``to_dict()`` is ``piles.json``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..fit import Cylinder, Plane
from ..least_depth import least_of
from ..outputs import Recorded, record_from, to_jsonable
from ..seabed import GridSurface
from .pairs import FrameFit, Level, Spacing

__all__ = ["PileSegment", "PileMeasure", "PileFit", "RejectedPile", "Spacing", "FrameFit", "PileResult",
           "plan_sigma", "Level"]


def plan_sigma(cov: np.ndarray) -> float:
    """A plan centre's 1-sigma (m) from its covariance (the first two rows and columns):
    the root of the mean of the two variances.

    Examples
    --------
    >>> plan_sigma(np.diag([9e-6, 16e-6, 1.0])) == math.sqrt(12.5e-6)
    True
    """
    c = np.asarray(cov, np.float64)
    return math.sqrt(max(float(c[0, 0] + c[1, 1]) / 2, 0.0))


@dataclass(frozen=True, eq=False)
class PileSegment:
    """The points of one pile: all, top face and side (arrays, not serialised)."""

    points: np.ndarray
    top: np.ndarray
    side: np.ndarray
    ping: np.ndarray | None = None
    line: np.ndarray | None = None
    beam_angle: np.ndarray | None = None
    sigma_h: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class PileMeasure:
    """One pile measured in one iteration: its top centre by the method used and how well.

    Attributes
    ----------
    x, y, z : float
        Top centre (m).
    method : {"intersection", "centre"}
        The method that gave the centre.
    cov : ndarray, shape (2, 2)
        Covariance of the plan centre (m²), cluster-robust by ping where pings are known.
    sigma_xy : float
        Plan 1-sigma (m): the root of the mean of the covariance's diagonal.
    rms : float
        RMS residual of the points used (m).
    n_top, n_side : int
        Top and side points used.
    coverage : float
        Arc of the side scanned (deg; 0 for the centre method).
    top_coverage : float or None
        Share of the top disc's cells holding a point (centre method).
    tilt_deg, tilt_azimuth_deg : float or None
        Axis tilt from vertical and its bearing (intersection method).
    cylinder, plane : Cylinder or None, Plane or None
        The fitted models (intersection method).
    radius_fitted : float or None
        The radius the side points show when fitted freely (m).
    radius_used : float or None
        The radius of the cylinder used (m).
    radius_fitted_sigma : float
        The 1-sigma of ``radius_fitted`` (m), cluster-robust by ping (NaN: none).
    tilt_held : bool
        The data did not show a tilt (99.9 %): the axis was held plumb, and the plan
        covariance carries the tilt they allow.
    radius_gradient : tuple of float or None
        How the plan centre moves per metre of the radius held fixed (a side seen from one
        direction puts the axis a radius behind it; None when the radius was fitted, or
        for a plain mean of the top).
    alternatives : dict
        With both methods, each method's centre (``x, y, z, sigma_xy`` and, for the
        centre method, ``cov`` and ``top_coverage``).
    line_sigma_xy : float
        The part of ``sigma_xy`` the jackknife adds (m; NaN: not computed;
        :func:`~mbinspect.piles.jackknife.line_jackknife`).
    jackknife : str
        Its units: "lines" (the lines' disagreement), "ping blocks and beam-angle sectors"
        (a pile seen by one or two lines, both jackknifes added), "ping blocks" (the same
        without beam angles) or "".
    """

    x: float
    y: float
    z: float
    method: str
    cov: np.ndarray
    sigma_xy: float
    rms: float
    n_top: int
    n_side: int
    coverage: float = 0.0
    top_coverage: float | None = None
    tilt_deg: float | None = None
    tilt_azimuth_deg: float | None = None
    cylinder: Cylinder | None = None
    plane: Plane | None = None
    radius_fitted: float | None = None
    radius_used: float | None = None
    flags: tuple[str, ...] = ()
    alternatives: dict[str, dict[str, Any]] = field(default_factory=dict)
    line_sigma_xy: float = math.nan
    jackknife: str = ""
    radius_fitted_sigma: float = math.nan
    tilt_held: bool = False
    radius_gradient: tuple[float, float] | None = None

    @property
    def centre(self) -> np.ndarray:
        """The top centre as an array (3,)."""
        return np.array([self.x, self.y, self.z])


@dataclass(frozen=True)
class PileFit:
    """One pile: top centre (x, y, z), radius, tilt, quality and the reasons for doubt.

    ``x, y, z`` are the top centre by ``method``. With both methods the other method's
    centre is in ``alternatives``. ``top_z`` is the top's level with the survey lines'
    vertical offsets fitted out (:mod:`~mbinspect.piles.level`) and ``top_z_sigma`` its
    1-sigma (NaN: the data cannot show it); ``top_z_lower_bound`` when no beam reached the
    top; ``top_design``, ``top_deviation`` and ``top_verdict`` against a design's ``top``;
    ``top_lines`` each line's mean height over the top plane (what the levels are fitted from);
    ``least`` the top's least depth (:func:`~mbinspect.piles.level.pile_least_depth`).
    """

    id: int
    x: float
    y: float
    z: float
    radius: float
    tilt_deg: float | None
    tilt_azimuth_deg: float | None
    method: str
    n_top: int
    n_side: int
    side_coverage_deg: float
    rms: float
    sigma_xy: float
    flags: tuple[str, ...] = ()
    radius_fitted: float | None = None
    top_coverage: float | None = None
    alternatives: dict[str, dict[str, float]] = field(default_factory=dict)
    group: int = 1
    line_sigma_xy: float = math.nan
    jackknife: str = ""
    sources: tuple[dict[str, Any], ...] = field(default=(), repr=False)
    tilt_held: bool = False
    top_z: float | None = None
    top_z_sigma: float = math.nan
    top_z_lower_bound: bool = False
    top_design: float | None = None
    top_deviation: float | None = None
    top_verdict: str | None = None
    top_lines: tuple[dict[str, Any], ...] = field(default=(), repr=False)
    least: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """One row of ``piles.json``; the other method's centre under ``methods``."""
        d: dict[str, Any] = {
            "id": self.id, "group": self.group, "x": self.x, "y": self.y, "z": self.z, "radius": self.radius,
            "tilt_deg": self.tilt_deg, "tilt_azimuth_deg": self.tilt_azimuth_deg,
            "tilt_held": self.tilt_held, "method": self.method, "n_top": self.n_top, "n_side": self.n_side,
            "side_coverage_deg": self.side_coverage_deg, "rms": self.rms,
            "sigma_xy": self.sigma_xy, "line_sigma_xy": self.line_sigma_xy,
            "jackknife": self.jackknife or None, "flags": list(self.flags),
            "radius_fitted": self.radius_fitted, "top_coverage": self.top_coverage,
            "top_z": self.top_z, "top_z_sigma": self.top_z_sigma,
            "top_z_lower_bound": self.top_z_lower_bound, "top_design": self.top_design,
            "top_deviation": self.top_deviation, "top_verdict": self.top_verdict,
            "top_lines": list(self.top_lines), **self.least,
        }
        if self.alternatives:
            d["methods"] = self.alternatives
        d["sources"] = list(self.sources)
        return to_jsonable(d)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> PileFit:
        """The pile of a ``piles.json`` row (:meth:`to_dict`'s inverse)."""
        return record_from(cls, d, jackknife=d.get("jackknife") or "", alternatives=d.get("methods", {}),
                           least=least_of(d))


@dataclass(frozen=True)
class RejectedPile:
    """A candidate that is not a standing pile, or that the data cannot measure, with why.

    Attributes
    ----------
    x, y, z : float
        Where it stands (m): its top centre, or its soundings' mean and highest.
    top_height : float or None
        Its top above the seabed (m; None: not measured).
    tilt_deg, radius_fitted : float or None
        What its fit showed.
    reasons : tuple of str
    """

    x: float
    y: float
    z: float
    top_height: float | None
    tilt_deg: float | None
    radius_fitted: float | None
    reasons: tuple[str, ...]

    def to_dict(self) -> dict[str, Any]:
        """One row of ``rejected`` in ``piles.json``."""
        return to_jsonable({"x": self.x, "y": self.y, "z": self.z, "top_height": self.top_height,
                            "tilt_deg": self.tilt_deg, "radius_fitted": self.radius_fitted,
                            "reasons": list(self.reasons)})

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> RejectedPile:
        """The record of a ``rejected`` row."""
        return record_from(cls, d)


@dataclass(frozen=True, eq=False)
class PileResult:
    """Everything :func:`~mbinspect.piles.locate_piles` measured; ``to_dict()`` is ``piles.json``.

    Attributes
    ----------
    piles : tuple of PileFit
        By the chosen method (the intersection method's with ``method="both"``).
    spacings : tuple of Spacing
        Every pair of ``piles``.
    iterations : tuple of dict
        Centres and spacings after each iteration (the paper's convergence).
    parameters : dict
        The options (``PileOptions.to_dict()``), the design's source, the input and the
        software version; the command line adds the input file's size and sha256 and the
        command.
    warnings : tuple of str
    segments, seabed, cylinders
        The points, seabed and models behind the answer (for figures; not serialised).
    other_spacings, other_piles
        With ``method="both"``: the centre method's spacings and piles.
    segmentation : dict
        Per pile, how the top/side split went, and the backscatter threshold used.
    frames : tuple of FrameFit
        Per jacket, the design frame fitted to the measured centres.
    rejected : tuple of dict
        Candidates that cannot be standing piles, with the reasons (:mod:`.accept`).
    levels : tuple of Level
        Every pair of a jacket's top level difference (:mod:`.level`).
    """

    piles: tuple[PileFit, ...]
    spacings: tuple[Spacing, ...]
    iterations: tuple[dict[str, Any], ...]
    parameters: dict[str, Any]
    warnings: tuple[str, ...] = ()
    segments: dict[int, PileSegment] = field(default_factory=dict, repr=False)
    seabed: GridSurface | Recorded | None = field(default=None, repr=False)
    cylinders: dict[int, Cylinder] = field(default_factory=dict, repr=False)
    other_spacings: tuple[Spacing, ...] = ()
    other_piles: tuple[PileFit, ...] = ()
    segmentation: dict[str, Any] = field(default_factory=dict)
    frames: tuple[FrameFit, ...] = ()
    rejected: tuple[RejectedPile, ...] = ()
    levels: tuple[Level, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        """The result as JSON-ready dicts and lists (``piles.json``)."""
        return {
            "piles": [p.to_dict() for p in self.piles],
            "other_piles": [p.to_dict() for p in self.other_piles],
            "spacings": [s.to_dict() for s in self.spacings + self.other_spacings],
            "iterations": to_jsonable(list(self.iterations)),
            "parameters": to_jsonable(self.parameters),
            "segmentation": to_jsonable(self.segmentation),
            "frames": [f.to_dict() for f in self.frames],
            "levels": [lv.to_dict() for lv in self.levels],
            "rejected": [r.to_dict() for r in self.rejected],
            "warnings": list(self.warnings),
            "seabed": self.seabed.to_dict() if self.seabed is not None else None,
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> PileResult:
        """The result of a ``piles.json`` (:func:`mbinspect.results.read_result`): ``to_dict()``
        of what it returns is ``d``; the soundings, models and seabed grid behind the answer
        are not in the file (the seabed's summary is kept)."""
        others = tuple(PileFit.from_dict(p) for p in d.get("other_piles", []))
        spacings = tuple(Spacing.from_dict(s) for s in d.get("spacings", []))
        split = len(spacings)
        if others and spacings:  # the other method's spacings follow, under their own method
            split = next((k for k, s in enumerate(spacings) if s.method != spacings[0].method), split)
        seabed = d.get("seabed")
        return cls(tuple(PileFit.from_dict(p) for p in d["piles"]), spacings[:split],
                   tuple(d.get("iterations", [])), dict(d.get("parameters", {})),
                   tuple(d.get("warnings", [])),
                   seabed=None if seabed is None else Recorded(seabed), other_spacings=spacings[split:],
                   other_piles=others, segmentation=dict(d.get("segmentation", {})),
                   frames=tuple(FrameFit.from_dict(f) for f in d.get("frames", [])),
                   rejected=tuple(RejectedPile.from_dict(r) for r in d.get("rejected", [])),
                   levels=tuple(Level.from_dict(r) for r in d.get("levels", [])))

    @property
    def ok(self) -> bool:
        """True when no pile is flagged and there is no warning."""
        return not self.warnings and not any(p.flags for p in self.piles)
