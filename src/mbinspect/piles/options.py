"""Every option of the pile pipeline, with its unit, default and check, declared once."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..beam import Beam
from ..checks import fail
from ..options import CHOICES, Options, crop_value, option, parse_crop

__all__ = ["PileOptions", "METHODS"]

#: Centre methods: the paper's two and both side by side.
METHODS = CHOICES["pile_method"]


def _coverage_deg(name: str, value: Any) -> float:
    from ..checks import within

    return within(name, value, 0.0, 360.0, unit="deg")


@dataclass(frozen=True)
class PileOptions(Options):
    """Options of :func:`~mbinspect.piles.locate_piles`; each is checked on creation.

    The table of every option (unit, default, meaning) is ``PileOptions.describe()``;
    ``mbinspect piles --help`` lists the same under their flags.

    Examples
    --------
    >>> PileOptions(radius=0.75, count=4).method
    'intersection'
    >>> PileOptions(radius=0.75, max_iterations=0)
    Traceback (most recent call last):
    ...
    mbinspect.errors.ParameterError: max_iterations: 0; expected a whole number >= 1
    """

    radius: float = option(unit="m", help="prior pile radius r", check="positive", metavar="R")
    count: int | None = option(None, help="number of piles K (K-means); found from the data if none",
                               check="count", kind=int, metavar="K")
    method: str = option("intersection", help="top-centre method", choices="pile_method")
    tolerance: float = option(0.05, unit="m", help="pass/fail tolerance on spacing deviations (decided "
                              "at 95 per cent: pass, fail or undecided)", check="positive")
    groups: str = option("auto", help="piles grouped into jackets by their spacing (auto), or one group "
                         "(none); a design with a group column decides", choices="pile_groups")
    all_pairs: bool = option(False, help="spacings between every pair of piles, not only within a jacket",
                             check="bool")
    frame_tolerance: float = option(0.05, unit="m", help="how far a pile may miss its jacket's fitted "
                                    "design frame (decided at 95 per cent)", check="positive")
    level_tolerance: float = option(0.02, unit="m", help="how far a top may miss the design's top level, "
                                    "and a level difference the design's (decided at 95 per cent)",
                                    check="positive")
    min_clearance: float | None = option(None, unit="m", check="positive", kind=float,
                                         help="the least depth every pile top must keep below the stated "
                                              "datum (pass, fail or undecided at 95 per cent)")
    crop: tuple[Any, ...] | None = option(
        None, unit="m", help="keep only this box (xmin,ymin,xmax,ymax) or polygon (x1,y1,x2,y2,...)",
        check=crop_value, kind=tuple, metavar="XMIN,YMIN,XMAX,YMAX", parse=parse_crop)
    min_height: float = option(1.0, unit="m", help="pile points stand this far above the local seabed",
                               check="positive")
    seabed_cell: float = option(1.0, unit="m", help="local seabed grid cell", check="positive")
    seabed_window: float | None = option(None, unit="m", help="seabed opening window (none: max(5, 4 r + 1))",
                                         check="positive", kind=float)
    window: float = option(0.1, unit="m", help="the paper's top elevation window", check="positive")
    step: float = option(0.01, unit="m", help="the window's step", check="positive")
    ks: float = option(0.1, unit="m", help="the paper's k_s: centre method radius r + k_s",
                       check="non_negative")
    threshold: float = option(0.06, unit="m", help="inlier distance of the cylinder and plane fits",
                              check="positive")
    use_intensity: bool = option(True, help="drop points darker than an Otsu backscatter threshold",
                                 check="bool", flag="intensity")
    segmentation: str = option("joint", help="window + normals + backscatter (joint) or the window "
                               "alone (paper)", choices="segmentation")
    weights: str = option("angle", help="weigh each side sounding by the noise at its beam angle, measured "
                          "on the pile's own side (angle), by the file's horizontal uncertainty (file), "
                          "or not at all (none)", choices="pile_weights")
    axis_mode: str = option("auto", help="hold a pile's axis plumb where the data do not show a tilt "
                            "(95 per cent) (auto), or always fit the tilt (free, the paper)",
                            choices="axis_mode")
    radius_mode: str = option("auto", help="keep the prior radius (fixed, the paper), fit it (free), fit "
                              "it where a pile's side supports it (each), or that and one radius for all "
                              "the piles where theirs together reject the prior (auto)",
                              choices="radius_mode")
    delta: float = option(0.01, unit="m", help="stop when every spacing changes by less than this",
                          check="positive")
    max_iterations: int = option(20, help="most iterations", check="count", metavar="N")
    max_tilt_deg: float = option(15.0, unit="deg", help="largest tilt a cylinder hypothesis may have "
                                 "(beyond the design's largest rake, when the design gives rakes)",
                                 check="angle", flag="max-tilt")
    min_top: int = option(20, help="flag a pile with fewer top points", check="whole", metavar="N")
    min_side: int = option(50, help="flag a pile with fewer side points", check="whole", metavar="N")
    min_coverage_deg: float = option(60.0, unit="deg", help="flag a pile whose side is scanned over a "
                                     "narrower arc", check=_coverage_deg, flag="min-coverage")
    max_sigma: float = option(0.005, unit="m", help="flag a pile whose plan 1-sigma exceeds this",
                              check="positive")
    beam_width_deg: float = option(0.0, unit="deg", check="non_negative",
                                   help="the sonar's beam width (-3 dB, across and along track): each pile "
                                   "measured again from soundings corrected for what the beam does to them "
                                   "(0: thin beams, no correction)")
    detection: str = option("auto", choices="detection",
                            help="the sonar's bottom detection, for the beam correction: amplitude, phase, "
                            "leading-edge, or auto (amplitude near nadir, phase outside)")
    phase_from_deg: float = option(15.0, unit="deg", check="non_negative",
                                   help="beam angle from which auto detection uses the phase")
    beam_contrast_db: float | None = option(None, unit="dB", check="non_negative", kind=float,
                                            help="how much stronger the piles' echo is than the seabed's, "
                                            "for the beam correction (none: from the soundings' intensity "
                                            "in dB where they have one, else 20 dB)")
    seed: int = option(0, help="random seed", check="seed")

    def check_together(self) -> None:
        if self.step > self.window:
            raise fail("step", self.step, f"at most the window ({self.window} m)")
        if self.beam_width_deg > 10:
            raise fail("beam_width_deg", self.beam_width_deg, "a beam width of 0 (thin beams) to 10 deg")

    @property
    def opening_window(self) -> float:
        """The seabed opening window used (m): given, or max(5, 4 r + 1)."""
        return self.seabed_window if self.seabed_window is not None else max(5.0, 4 * self.radius + 1)

    @property
    def neighbourhood(self) -> float:
        """How far around a pile (m) its measurement looks: the seabed's opening window, ten
        radii and 4 m (a jacket's pile, its side's noise, the pings that place its beams); a
        survey tile holds this much around every pile it owns."""
        return self.opening_window + 10 * self.radius + 4.0

    def beam(self) -> Beam | None:
        """The survey's beam for the correction, or None when the beams are taken as thin."""
        if self.beam_width_deg <= 0:
            return None
        return Beam(beam_across_deg=self.beam_width_deg, detection=self.detection,
                    phase_from_deg=self.phase_from_deg)

    def value_for_json(self, name: str) -> Any:
        return self.opening_window if name == "seabed_window" else getattr(self, name)
