"""The presets' options (jacket, wharf, reef-field), their defaults and checks."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

from ..checks import fail, finite
from ..errors import ParameterError
from ..options import Options, option
from ..reef_designs import BUILTIN_DESIGNS
from .sonar import DEFAULT_SONAR, Sonar, SonarChoice, named_sonar


def _under_water(name: str, value: float) -> float:
    """A seabed below the water surface (a negative elevation), where a sonar can sound it."""
    value = finite(name, value)
    if not value < -1.0:
        raise fail(name, value, "a seabed elevation below -1 m (under the water, beneath the transducer)")
    return value



@dataclass(frozen=True)
class JacketOptions(Options):
    """The ``jacket`` preset, after the pile paper: a four-pile jacket, 22 m sides.

    Every field can be overridden (``simulate("jacket", radius=1.0)`` or
    ``mbinspect simulate jacket --radius 1.0``). Lengths in m, angles in degrees.
    """

    side: float = option(22.0, unit="m", help="design side of the square of piles", check="positive")
    radius: float = option(0.75, unit="m", help="pile radius", check="positive")
    top: float = option(-16.0, unit="m", help="design top elevation", check="finite")
    seabed: float = option(-21.0, unit="m", help="seabed elevation at the jacket centre",
                           check=_under_water)
    slope_deg: float = option(0.5, unit="deg", help="seabed slope", check="non_negative")
    sand_wave_amplitude: float = option(0.0, unit="m", help="sand wave half height", check="non_negative")
    roughness: float = option(0.03, unit="m", help="seabed roughness RMS", check="non_negative")
    position_scatter: float = option(0.03, unit="m", check="non_negative",
                                     help="as-built deviation of each pile from design (1 sigma)")
    top_scatter: float = option(0.02, unit="m", check="non_negative",
                                help="as-built deviation of each top elevation (1 sigma)")
    tilt_max_deg: float = option(1.0, unit="deg", check="non_negative",
                                 help="tilts drawn uniformly in [0, tilt_max]")
    lines: str = option("west,east,south,north,tops", help="which survey lines to sail")
    line_offset: float = option(12.5, unit="m", check="non_negative",
                                help="distance of the '#' lines outside the piles")
    line_extent: float = option(36.0, unit="m", check="positive",
                                help="half-length of every line from the jacket centre")
    ping_spacing: float = option(0.05, unit="m", help="along-track ping spacing", check="positive")
    boulders: int = option(2, help="distractor boulders near the jacket", check="whole")
    origin_x: float = option(512300.0, unit="m", help="easting of the jacket centre", check="finite")
    origin_y: float = option(3456700.0, unit="m", help="northing of the jacket centre", check="finite")

    def check_together(self) -> None:
        """The lines sailed are known ones; the pile tops stand above the seabed."""
        names = [s.strip() for s in self.lines.split(",") if s.strip()]
        bad = [n for n in names if n not in JACKET_LINES]
        if not names or bad:
            raise fail("lines", bad[0] if bad else self.lines,
                       f"survey lines from {', '.join(JACKET_LINES)}, comma-separated")
        _tops_above(self.top, self.seabed)


@dataclass(frozen=True)
class ReefFieldOptions(Options):
    """The ``reef-field`` preset, after the reef paper: groups of 25 reefs at -17.3 m.

    ``groups`` lists the reef kind of each group (``cross2``, ``cross1``, ``hollow``,
    ``triangle``, ``cube`` or ``mixed``). Lengths in m, angles in degrees.
    """

    groups: str = option("cross2,cross2,cross2,cross1", help="reef kind per group")
    per_group: int = option(25, help="reefs per group (a square grid, jittered)", check="count")
    grid_spacing: float = option(6.0, unit="m", help="nominal spacing of reefs in a group", check="positive")
    jitter: float = option(0.8, unit="m", check="non_negative",
                           help="placement scatter of each reef (1 sigma)")
    plan_bearing_deg: float | None = option(None, unit="deg", check="finite", kind=float,
                                            help="the planned bearing of every reef (none: each at random)")
    bearing_scatter_deg: float = option(2.0, unit="deg", check="non_negative",
                                        help="how far each reef turns from the planned bearing (1 sigma)")
    reef_scale: float = option(1.0, check="positive",
                               help="as-built size of every reef relative to its design")
    group_spacing: float = option(55.0, unit="m", help="spacing of group centres", check="positive")
    seabed: float = option(-17.3, unit="m", help="seabed elevation at the field centre",
                           check=_under_water)
    slope_deg: float = option(0.3, unit="deg", help="seabed slope", check="non_negative")
    sand_wave_amplitude: float = option(0.0, unit="m", help="sand wave half height", check="non_negative")
    sand_wave_length: float = option(25.0, unit="m", help="sand wave length", check="non_negative")
    roughness: float = option(0.04, unit="m", help="seabed roughness RMS", check="non_negative")
    close_pairs: int = option(6, help="pairs moved to 0.3-0.9 m apart", check="whole")
    touching_pairs: int = option(0, help="pairs moved until they touch", check="whole")
    boulders: int = option(8, help="distractor boulders (r 0.25-0.5 m)", check="whole")
    rocks: int = option(0, check="whole",
                        help="rounded rocks of reef size (1.2-2.6 m across, 0.4-1.5 m proud, some two-lobed)")
    burial_max: float = option(0.0, unit="m", check="non_negative",
                               help="reefs sunk a further 0 to this many m into the seabed")
    debris: int = option(4, help="distractor debris items (< 1 m^2)", check="whole")
    overturned: int = option(0, check="whole",
                             help="units at rest on their side or upside down (each design's distinct ways)")
    tilt_max_deg: float = option(0.0, unit="deg", check="non_negative",
                                 help="units lean 0 to this many degrees (resting on a rock or an edge)")
    shore_width: float = option(0.0, unit="m", check="non_negative",
                                help="a steep rocky shore rising over this width north of the "
                                     "reefs (0: none)")
    line_spacing: float = option(22.0, unit="m", check="positive",
                                 help="spacing of the parallel survey lines")
    ping_spacing: float = option(0.55, unit="m", help="along-track ping spacing", check="positive")
    origin_x: float = option(402500.0, unit="m", help="easting of the field centre", check="finite")
    origin_y: float = option(3372800.0, unit="m", help="northing of the field centre", check="finite")

    def check_together(self) -> None:
        """The groups' kinds are designs; close and touching pairs take at most half the reefs."""
        kinds = [s.strip() for s in self.groups.split(",") if s.strip()]
        bad = [k for k in kinds if k not in BUILTIN_DESIGNS and k != "mixed"]
        if not kinds or bad:
            raise fail("groups", bad[0] if bad else self.groups,
                       f"reef kinds from {', '.join(BUILTIN_DESIGNS)}, mixed, comma-separated")
        most = self.per_group * len(kinds) // 2
        if self.close_pairs + self.touching_pairs > most:
            raise fail("touching_pairs" if self.touching_pairs else "close_pairs",
                       self.touching_pairs or self.close_pairs,
                       f"close_pairs + touching_pairs at most {most} (half the {2 * most} reefs)")


@dataclass(frozen=True)
class WharfOptions(Options):
    """The ``wharf`` preset: a row of four-pile jackets along a wharf, some of battered piles.

    ``rakes`` gives each jacket's pile rake 1:N (one horizontal over N vertical): ``0`` for
    vertical piles, ``6`` for 1:6 (9.5 deg), ``4`` for 1:4 (14 deg); battered piles lean
    outward from their jacket's centre. Lengths in m, angles in degrees.
    """

    rakes: str = option("0,6,4", help="per jacket, the rake 1:N of its piles (0: vertical)")
    side: float = option(14.0, unit="m", check="positive",
                         help="design side of each jacket's square of piles")
    gap: float = option(26.0, unit="m", check="non_negative",
                        help="clear distance between neighbouring jackets' nearest piles")
    radius: float = option(0.6, unit="m", help="pile radius", check="positive")
    top: float = option(-8.0, unit="m", help="design top elevation", check="finite")
    seabed: float = option(-14.0, unit="m", help="seabed elevation at the wharf centre",
                           check=_under_water)
    slope_deg: float = option(0.5, unit="deg", help="seabed slope", check="non_negative")
    roughness: float = option(0.03, unit="m", help="seabed roughness RMS", check="non_negative")
    position_scatter: float = option(0.03, unit="m", check="non_negative",
                                     help="as-built deviation of each pile from design (1 sigma)")
    top_scatter: float = option(0.02, unit="m", check="non_negative",
                                help="as-built deviation of each top elevation (1 sigma)")
    line_offset: float = option(10.0, unit="m", check="non_negative",
                                help="distance of the lines along the wharf outside the piles")
    ping_spacing: float = option(0.08, unit="m", help="along-track ping spacing", check="positive")
    origin_x: float = option(402800.0, unit="m", help="easting of the wharf centre", check="finite")
    origin_y: float = option(3372900.0, unit="m", help="northing of the wharf centre", check="finite")

    def check_together(self) -> None:
        """The rakes read; the pile tops stand above the seabed."""
        rakes(self.rakes)
        _tops_above(self.top, self.seabed)


#: Preset name -> options class.
PRESETS: dict[str, type[Options]] = {
    "jacket": JacketOptions,
    "wharf": WharfOptions,
    "reef-field": ReefFieldOptions,
}


def options_class(preset: str) -> type[Options]:
    """The options class of a preset (:data:`PRESETS`).

    Parameters
    ----------
    preset : str

    Returns
    -------
    type

    Examples
    --------
    >>> options_class("jacket")().side
    22.0
    """
    if preset not in PRESETS:
        raise ParameterError(f"preset: {preset!r}; expected one of {', '.join(PRESETS)}", option="preset")
    return PRESETS[preset]


def default_options(preset: str, sonar: str = DEFAULT_SONAR) -> dict[str, Any]:
    """Every option of a preset with its value before overrides (``--show-options``)."""
    return {**dataclasses.asdict(options_class(preset)()), "sonar": sonar,
            **dataclasses.asdict(named_sonar(sonar))}


def _tops_above(top: float, seabed: float) -> None:
    if top < seabed + 0.5:
        raise fail("top", top, f"a pile top at least 0.5 m above the seabed ({seabed} m)")


def option_fields(preset: str) -> list[dataclasses.Field[Any]]:
    """Every overridable option of a preset (its own fields, then the sonar's)."""
    return (list(dataclasses.fields(options_class(preset))) + list(dataclasses.fields(SonarChoice))
            + list(dataclasses.fields(Sonar)))


def rakes(text: str) -> list[float]:
    try:
        rakes = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise fail("rakes", text, "pile rakes 1:N per jacket, comma-separated (0 for vertical)") from None
    if not rakes or any(r != 0 and r < 1 for r in rakes):
        raise fail("rakes", text, "at least one jacket, each rake 0 (vertical) or N >= 1 for 1:N")
    return rakes


#: The survey lines the ``jacket`` preset can sail.
JACKET_LINES = ("west", "east", "south", "north", "tops", "tops-ew")
