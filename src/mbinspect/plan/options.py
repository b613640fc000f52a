"""The options of :func:`~mbinspect.plan.plan_survey`, as data."""

from __future__ import annotations

from dataclasses import dataclass

from ..checks import fail, within
from ..options import CHOICES, Options, option
from ..simulate.sonar import SONARS

__all__ = ["PlanOptions", "KNOT", "SOUND_SPEED"]

#: One knot in m/s.
KNOT = 1852.0 / 3600.0

#: The speed of sound the ping rate is limited by (m/s).
SOUND_SPEED = 1500.0

CHOICES["plan_sonar"] = tuple(SONARS)


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

    radius: float = option(unit="m", check="positive", metavar="R", help="pile radius")
    depth: float = option(unit="m", check="positive", metavar="D",
                          help="water depth at the structure: the seabed below the vertical reference")
    height: float | None = option(None, unit="m", check="positive", kind=float,
                                  help="how far the pile tops stand above the seabed (not needed when the "
                                       "design gives each pile's top)")
    target_sigma: float = option(0.01, unit="m", check="positive",
                                 help="the 1-sigma every spacing must reach")
    speed: float = option(4.0, unit="kn", check="positive", help="survey speed over the ground")
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
                                       "or auto: 0.3 and 0.5 of where a top is seen at the swath's edge")
    seeds: int = option(3, check="count", help="simulated surveys per candidate layout")
    max_seeds: int = option(9, check="count",
                            help="simulated surveys a layout predicted near the target gets at most, "
                                 "in batches of seeds, until its prediction is clear of the target")
    seed: int = option(0, check="seed", help="seed of the simulated surveys")
    tilt_max: float = option(1.0, unit="deg", check="non_negative",
                             help="as-built lean of the piles in the simulated surveys, drawn up to this")
    workers: int = option(2, check="count", help="candidate surveys simulated at once, in as many processes")

    def check_together(self) -> None:
        """Offsets parse as positive numbers; ``max_seeds`` is at least ``seeds``."""
        self.offset_values()
        if self.max_seeds < self.seeds:
            raise fail("max_seeds", self.max_seeds, f"at least seeds ({self.seeds})")

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
