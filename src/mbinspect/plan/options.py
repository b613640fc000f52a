"""The options of :func:`~mbinspect.plan.plan_survey`, as data."""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..checks import fail, within
from ..options import CHOICES, Options, option
from ..simulate.sonar import SONARS
from .layouts import KNOT

__all__ = ["PlanOptions", "KNOT", "SOUND_SPEED", "S44_FEATURE", "ping_rate"]


#: The speed of sound the ping rate is limited by (m/s).
SOUND_SPEED = 1500.0

CHOICES["plan_sonar"] = tuple(SONARS)

#: IHO S-44 (edition 6) orders and the size (m) of the cubic feature each asks to detect
#: (None: no feature detection asked).
S44_FEATURE: dict[str, float | None] = {"exclusive": 0.5, "special": 1.0, "1a": 2.0, "1b": None, "2": None}
CHOICES["s44_order"] = tuple(S44_FEATURE)


def _max_angle(name: str, value: float) -> float:
    return within(name, value, 10.0, 80.0, unit="deg")


@dataclass(frozen=True)
class PlanOptions(Options):
    """Options of :func:`~mbinspect.plan.plan_survey`; each is checked on creation.

    Examples
    --------
    >>> PlanOptions(radius=0.75, depth=21.0).speed
    4.0
    >>> PlanOptions(radius=0.75, depth=-21.0)
    Traceback (most recent call last):
    ...
    mbinspect.errors.ParameterError: depth: -21.0; expected a positive finite number
    """

    depth: float = option(unit="m", check="positive", metavar="D",
                          help="water depth at the structure: the seabed below the vertical reference")
    radius: float | None = option(None, unit="m", check="positive", kind=float, metavar="R",
                                  help="pile radius (a pile design; a reef plan takes --kind)")
    height: float | None = option(None, unit="m", check="positive", kind=float,
                                  help="how far the pile tops stand above the seabed (not needed when the "
                                       "design gives each pile's top)")
    target_sigma: float = option(0.01, unit="m", check="positive",
                                 help="the 1-sigma every spacing must reach")
    speed: float = option(4.0, unit="kn", check="positive", help="survey speed over the ground")
    min_speed: float = option(2.0, unit="kn", check="non_negative",
                              help="the slowest a pile design's lines may be sailed: each layout is also "
                                   "tried at half --speed, not below this (more pings on each pile may "
                                   "meet the target sooner than more lines)")
    max_angle: float = option(60.0, unit="deg", check=_max_angle,
                              help="the outermost beam kept, from vertical (the swath is twice it)")
    sonar: str = option("shallow-beam", choices="plan_sonar",
                        help="the named sonar whose beam and error model the prediction simulates")
    sonar_from: str | None = option(None, kind=str, metavar="FILE",
                                    help="one of your own sonar files (GSF, KMALL, .all, XTF): its swath, "
                                         "beams per ping, ping rate and seabed noise by beam angle replace "
                                         "the named sonar's")
    max_ping_rate: float = option(40.0, unit="Hz", check="positive",
                                  help="the sonar's highest ping rate (the two-way travel time to the "
                                       "swath's edge may allow fewer)")
    turn_s: float = option(180.0, unit="s", check="non_negative",
                           help="time from the end of one line to the start of the next")
    margin: float = option(20.0, unit="m", check="non_negative",
                           help="how far each line runs on beyond the outermost piles")
    offsets: str = option("auto", help="offsets (m) of the lines outside the outer piles, comma-separated, "
                                       "or auto: 0.3 and 0.45 (the pile paper's '#') of where a top is "
                                       "seen at the swath's edge")
    seeds: int = option(3, check="count", help="simulated surveys per candidate layout")
    max_seeds: int = option(9, check="count",
                            help="simulated surveys a layout predicted near the target gets at most, "
                                 "as many at once as workers, until it meets the target or cannot")
    seed: int = option(0, check="seed", help="seed of the simulated surveys")
    tilt_max: float = option(1.0, unit="deg", check="non_negative",
                             help="as-built lean of the piles in the simulated surveys, drawn up to this")
    workers: int = option(2, check="count", help="candidate surveys simulated at once, in as many processes")
    kind: str | None = option(None, kind=str, metavar="DESIGN",
                              help="a reef plan's units' design (cross2, cube, a JSON design) where the plan "
                                   "has no kind column; its units are surveyed as built to it")
    s44_order: str = option("1a", choices="s44_order",
                            help="a reef plan's IHO S-44 order: its feature detection (exclusive 0.5 m, "
                                 "special 1 m, 1a 2 m cubes) is tried with cubes laid among the units; "
                                 "1b and 2 ask no feature detection")
    feature_soundings: int = option(3, check="count",
                                    help="soundings a cube of the order's size must get to count as detected")
    min_soundings: int = option(50, check="count",
                                help="soundings every reef unit must get in every simulated survey")
    overlaps: str = option("0,0.25,0.5,0.75",
                           help="a reef plan's candidate swath overlaps between adjacent lines (shares of "
                                "the swath, comma-separated, each in [0, 0.9])")

    def check_together(self) -> None:
        """Offsets and overlaps parse; ``max_seeds`` is at least ``seeds``."""
        self.offset_values()
        self.overlap_values()
        if self.max_seeds < self.seeds:
            raise fail("max_seeds", self.max_seeds, f"at least seeds ({self.seeds})")

    def slower_speeds(self) -> tuple[float, ...]:
        """The speed (kn) below ``speed`` a pile design's layouts are also tried at: half of
        it, not below ``min_speed`` (none when that is not below ``speed``).

        >>> PlanOptions(radius=0.75, depth=21.0).slower_speeds()
        (2.0,)
        >>> PlanOptions(radius=0.75, depth=21.0, speed=3.0).slower_speeds()
        (2.0,)
        """
        slow = max(self.speed / 2, self.min_speed)
        return (slow,) if slow < self.speed - 1e-9 else ()

    def offset_values(self) -> tuple[float, ...] | None:
        """The offsets given (m), or None for ``auto``."""
        text = self.offsets.strip().lower()
        if text == "auto":
            return None
        try:
            values = tuple(float(v) for v in text.split(",") if v.strip())
        except ValueError:
            raise fail("offsets", self.offsets, "auto or numbers of metres, comma-separated") from None
        if not values or any(not 0 < v < 1000 for v in values):
            raise fail("offsets", self.offsets, "auto or positive numbers of metres, comma-separated")
        return values

    def overlap_values(self) -> tuple[float, ...]:
        """The overlaps given, each a share of the swath in [0, 0.9]."""
        expected = "shares of the swath in [0, 0.9], comma-separated"
        try:
            values = tuple(float(v) for v in self.overlaps.split(",") if v.strip())
        except ValueError:
            raise fail("overlaps", self.overlaps, expected) from None
        if not values or any(not 0.0 <= v <= 0.9 for v in values):
            raise fail("overlaps", self.overlaps, expected)
        return tuple(sorted(set(values)))


def ping_rate(options: PlanOptions) -> float:
    """Pings a second: the sonar's highest rate, or the two-way travel time to the swath's
    edge on the seabed, whichever is slower."""
    slant = options.depth / math.cos(math.radians(options.max_angle))
    return min(options.max_ping_rate, SOUND_SPEED / (2.0 * slant))
