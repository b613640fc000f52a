"""Every option of the reef pipeline, with its unit, default and check, declared once."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..beam import Beam
from ..checks import fail
from ..options import CHOICES, Options, crop_value, option, parse_crop
from ..reef_designs import ReefDesign, parse_designs

__all__ = ["ReefOptions", "REEF_METHODS"]

#: Extraction methods: ours and the paper's plain one.
REEF_METHODS = CHOICES["reef_method"]


def _designs(name: str, value: Any) -> tuple[ReefDesign, ...]:
    return parse_designs(value)


@dataclass(frozen=True)
class ReefOptions(Options):
    """Options of :func:`~mbinspect.reefs.extract_reefs`; each is checked on creation.

    ``design`` takes built-in design names or JSON design files, comma-separated, or
    :class:`~mbinspect.reef_designs.ReefDesign` objects, and holds the designs read. The table
    of every option is ``ReefOptions.describe()``; ``mbinspect reefs --help`` lists the
    same under their flags.

    Examples
    --------
    >>> ReefOptions(design="cross2").design[0].name
    'cross2'
    >>> ReefOptions(max_slope_deg=100)
    Traceback (most recent call last):
    ...
    mbinspect.errors.ParameterError: max_slope_deg: 100; expected a number > 0 deg and < 90 deg
    """

    method: str = option("local", help="ours (local) or the paper's plain method (radius filter, one "
                         "plane, Euclidean clusters)", choices="reef_method")
    tolerance: float = option(1.5, unit="m", help="matching distance to the reference", check="positive")
    crop: tuple[Any, ...] | None = option(
        None, unit="m", help="keep only this box (xmin,ymin,xmax,ymax) or polygon (x1,y1,x2,y2,...)",
        check=crop_value, kind=tuple, metavar="XMIN,YMIN,XMAX,YMAX", parse=parse_crop)
    exclude_rough: bool = option(True, help="exclude steep, rough terrain automatically", check="bool")
    max_slope_deg: float = option(15.0, unit="deg", help="steeper terrain is excluded", check="angle",
                                  flag="max-slope")
    max_roughness: float = option(0.2, unit="m", help="rougher terrain (RMS) is excluded", check="positive")
    noise_radius: float = option(0.5, unit="m", help="the paper's radius filter r", check="positive")
    noise_neighbors: int = option(3, help="radius filter: noise if at most this many neighbours",
                                  check="whole", metavar="N")
    noise_spacing: float = option(3.0, help="the radius filter's radius grows to this many local sounding "
                                  "spacings where soundings lie farther apart (deep or sparse lines; 0: the "
                                  "fixed noise_radius; the paper's method keeps it fixed)",
                                  check="non_negative", metavar="F")
    beam_width_deg: float = option(1.0, unit="deg", help="the sonar's beam width: a run stops when the "
                                   "footprint at the survey's depth is wider than objects of min_area; "
                                   "with beam_correction, the cones the bloom is cast through",
                                   check="angle")
    beam_correction: bool = option(False, help="take the beam's bloom off every footprint: the concrete's "
                                   "echo heard beyond its edges through cones of beam_width_deg (off: "
                                   "thin beams, the footprints as the soundings draw them)", check="bool")
    detection: str = option("auto", choices="detection",
                            help="the sonar's bottom detection, for the beam correction: amplitude, phase, "
                            "leading-edge, or auto (amplitude near nadir, phase outside)")
    beam_contrast_db: float | None = option(None, unit="dB", check="non_negative", kind=float,
                                            help="how much stronger the reefs' echo is than the seabed's, "
                                            "for the beam correction (none: from the soundings' intensity "
                                            "where they have one, else 20 dB)")
    statistical_k: int = option(8, help="statistical filter neighbours on the reef points (0: off)",
                                check="whole", metavar="K")
    statistical_ratio: float = option(3.0, help="statistical filter: standard deviations kept (mean "
                                      "and spread over the reef points within 5-10 m)",
                                      check="positive", metavar="R")
    seabed: str = option("auto", help="RANSAC plane, local grid, or the plane where it fits (auto)",
                         choices="seabed")
    plane_threshold: float = option(0.5, unit="m", help="the paper's RANSAC distance D", check="positive")
    confidence: float = option(0.99, help="the paper's RANSAC confidence q", check="fraction", metavar="Q")
    max_plane_dev: float = option(0.08, unit="m", help="auto keeps the plane while it departs from the "
                                  "local seabed by at most this", check="positive")
    seabed_cell: float = option(0.5, unit="m", help="local seabed grid cell", check="positive")
    seabed_window: float = option(6.0, unit="m", help="local seabed opening window (wider than a reef)",
                                  check="positive")
    min_height: float = option(0.3, unit="m", help="reef core height above the seabed", check="positive")
    foot_height: float = option(0.15, unit="m", help="reef foot height above the seabed", check="positive")
    cell: float = option(0.1, unit="m", help="plan raster cell of the footprints", check="positive")
    reef_area: float | None = option(None, unit="m²", help="single-reef footprint (none: learnt)",
                                     check="positive", kind=float, metavar="M2")
    design: Any = option(None, help="the reef designs deployed: built-in names (cross2, cross1, hollow, "
                         "triangle) or JSON design files, comma-separated; each reef is then fitted by "
                         "its design", check=_designs, kind=str, metavar="NAMES")
    min_area: float = option(1.0, unit="m²", help="smaller objects are not reefs", check="positive",
                             metavar="M2")
    max_elongation: float = option(2.5, help="reefs are compact: a footprint longer than this many times "
                                   "its width is a ridge (a sand-wave crest, a pipe) and is listed among the "
                                   "others (0: off)", check="non_negative", metavar="RATIO")
    design_misfit_max: float = option(0.1, help="with designs: a candidate whose best design leaves more "
                                      "than this share of its edge soundings on the wrong side is not a reef",
                                      check="fraction", metavar="SHARE")
    design_scale_tolerance: float = option(0.15, help="with designs: reefs are built within this fraction of "
                                           "their design's size; a rounded rock fits one only much smaller",
                                           check="fraction", metavar="SHARE")
    rounded_spread: float = option(0.12, help="rocks are rounded: a candidate whose highest soundings "
                                   "(three in ten) spread (10th to 90th percentile) over at least this share "
                                   "of its height, with few soundings near its top (rounded_plateau), is a "
                                   "rock (0: off)",
                                   check="non_negative", metavar="SHARE")
    rounded_plateau: float = option(0.42, help="rocks are rounded: at most this share of a rock's soundings "
                                    "lie within 0.15 of its height below its top (a reef's flat top holds "
                                    "more)", check="fraction", metavar="SHARE")
    dome_misfit: float = option(0.12, help="rocks are domes: a candidate whose upper soundings (above 0.3 "
                                "of its height) fit a quadratic surface within this share of its height "
                                "(RMS), curving down by at least dome_drop, is a rock (0: off)",
                                check="non_negative", metavar="SHARE")
    dome_drop: float = option(0.2, help="rocks are domes: the least drop of that surface, as a share of the "
                              "candidate's height, across half its thickest part along its most curved "
                              "direction (a reef's flat top, or a hollow square's, does not drop)",
                              check="non_negative", metavar="SHARE")
    min_pings: int = option(3, help="a reef's soundings must come from at least this many pings (where the "
                            "input has pings): one ping's streak across a ripple crest has no plan shape",
                            check="count", metavar="N")
    group_link: float = option(12.0, unit="m", help="reefs closer than this (chained) form a group",
                               check="positive")
    cluster_eps: float = option(0.5, unit="m", help="the paper's Euclidean clustering distance "
                                "(paper method)", check="positive")
    placement_tolerance: float = option(0.5, unit="m", check="positive",
                                        help="how far a reef may land from its planned position (with "
                                             "--plan; decided at 95 per cent)")
    position_sigma: float = option(0.05, unit="m", check="positive",
                                   help="a reef centre's 1-sigma for the placement verdict (the studies: "
                                        "2.5 cm RMS with a design fit, 4 cm without; add the positioning's)")
    bearing_sigma_deg: float = option(1.0, unit="deg", check="positive",
                                      help="a fitted design's bearing 1-sigma (the studies: 0.65 deg RMS "
                                           "on thin rays); told the beam, the footprint's share is added")
    min_clearance: float | None = option(None, unit="m", check="positive", kind=float,
                                         help="the least depth every object must keep below the stated "
                                              "datum (pass, fail or undecided at 95 per cent)")
    seed: int = option(0, help="random seed", check="seed")

    def check_together(self) -> None:
        if self.foot_height > self.min_height:
            raise fail("foot_height", self.foot_height, f"at most min_height ({self.min_height} m)")

    def beam(self) -> Beam | None:
        """The survey's beam for the footprint correction, or None when it is off."""
        if not self.beam_correction:
            return None
        return Beam(beam_across_deg=self.beam_width_deg, detection=self.detection)

    @property
    def designs(self) -> tuple[ReefDesign, ...]:
        """The designs deployed (empty when none was given)."""
        return self.design or ()

    def value_for_json(self, name: str) -> Any:
        if name == "design":
            return [d.to_dict() for d in self.designs] or None
        return getattr(self, name)
