"""The presets' options (jacket, wharf, reef-field), their defaults and checks."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

from ..checks import fail
from ..designs import BUILTIN_DESIGNS
from ..errors import ParameterError
from .sonar import DEFAULT_SONAR, Sonar, SonarChoice, named_sonar


@dataclass(frozen=True)
class JacketOptions:
    """The ``jacket`` preset, after the pile paper: a four-pile jacket, 22 m sides.

    Every field can be overridden (``simulate("jacket", radius=1.0)`` or
    ``mbinspect simulate jacket --radius 1.0``). Lengths in m, angles in degrees.
    """

    side: float = 22.0  #: design side of the square of piles
    radius: float = 0.75  #: pile radius
    top: float = -16.0  #: design top elevation
    seabed: float = -21.0  #: seabed elevation at the jacket centre
    slope_deg: float = 0.5  #: seabed slope
    sand_wave_amplitude: float = 0.0  #: sand wave half height
    roughness: float = 0.03  #: seabed roughness RMS
    position_scatter: float = 0.03  #: as-built deviation of each pile from design (1 sigma)
    top_scatter: float = 0.02  #: as-built deviation of each top elevation (1 sigma)
    tilt_max_deg: float = 1.0  #: tilts drawn uniformly in [0, tilt_max]
    lines: str = "west,east,south,north,tops"  #: which survey lines to sail
    line_offset: float = 12.5  #: distance of the '#' lines outside the piles
    line_extent: float = 36.0  #: half-length of every line from the jacket centre
    ping_spacing: float = 0.05  #: along-track ping spacing
    boulders: int = 2  #: distractor boulders near the jacket
    origin_x: float = 512300.0  #: easting of the jacket centre
    origin_y: float = 3456700.0  #: northing of the jacket centre


@dataclass(frozen=True)
class ReefFieldOptions:
    """The ``reef-field`` preset, after the reef paper: groups of 25 reefs at -17.3 m.

    ``groups`` lists the reef kind of each group (``cross2``, ``cross1``, ``hollow``,
    ``triangle``, ``cube`` or ``mixed``). Lengths in m, angles in degrees.
    """

    groups: str = "cross2,cross2,cross2,cross1"  #: reef kind per group
    per_group: int = 25  #: reefs per group (a square grid, jittered)
    grid_spacing: float = 6.0  #: nominal spacing of reefs in a group
    jitter: float = 0.8  #: placement scatter of each reef (1 sigma)
    reef_scale: float = 1.0  #: as-built size of every reef relative to its design
    group_spacing: float = 55.0  #: spacing of group centres
    seabed: float = -17.3  #: seabed elevation at the field centre
    slope_deg: float = 0.3  #: seabed slope
    sand_wave_amplitude: float = 0.0  #: sand wave half height
    sand_wave_length: float = 25.0  #: sand wave length
    roughness: float = 0.04  #: seabed roughness RMS
    close_pairs: int = 6  #: pairs moved to 0.3-0.9 m apart
    touching_pairs: int = 0  #: pairs moved until they touch
    boulders: int = 8  #: distractor boulders (r 0.25-0.5 m)
    rocks: int = 0  #: rounded rocks of reef size (1.2-2.6 m across, 0.4-1.5 m proud, some two-lobed)
    burial_max: float = 0.0  #: reefs sunk a further 0 to this many m into the seabed
    debris: int = 4  #: distractor debris items (< 1 m^2)
    shore_width: float = 0.0  #: a steep rocky shore rising over this width north of the reefs (0 = none)
    line_spacing: float = 22.0  #: spacing of the parallel survey lines
    ping_spacing: float = 0.55  #: along-track ping spacing
    origin_x: float = 402500.0  #: easting of the field centre
    origin_y: float = 3372800.0  #: northing of the field centre


@dataclass(frozen=True)
class WharfOptions:
    """The ``wharf`` preset: a row of four-pile jackets along a wharf, some of battered piles.

    ``rakes`` gives each jacket's pile rake 1:N (one horizontal over N vertical): ``0`` for
    vertical piles, ``6`` for 1:6 (9.5 deg), ``4`` for 1:4 (14 deg); battered piles lean
    outward from their jacket's centre. Lengths in m, angles in degrees.
    """

    rakes: str = "0,6,4"  #: per jacket, the rake 1:N of its piles (0: vertical)
    side: float = 14.0  #: design side of each jacket's square of piles
    gap: float = 26.0  #: clear distance between neighbouring jackets' nearest piles
    radius: float = 0.6  #: pile radius
    top: float = -8.0  #: design top elevation
    seabed: float = -14.0  #: seabed elevation at the wharf centre
    slope_deg: float = 0.5  #: seabed slope
    roughness: float = 0.03  #: seabed roughness RMS
    position_scatter: float = 0.03  #: as-built deviation of each pile from design (1 sigma)
    top_scatter: float = 0.02  #: as-built deviation of each top elevation (1 sigma)
    line_offset: float = 10.0  #: distance of the lines along the wharf outside the piles
    ping_spacing: float = 0.08  #: along-track ping spacing
    origin_x: float = 402800.0  #: easting of the wharf centre
    origin_y: float = 3372900.0  #: northing of the wharf centre


#: Preset name -> options class.
PRESETS: dict[str, type] = {
    "jacket": JacketOptions,
    "wharf": WharfOptions,
    "reef-field": ReefFieldOptions,
}


def options_class(preset: str) -> type:
    if preset not in PRESETS:
        raise ParameterError(f"preset: {preset!r}; expected one of {', '.join(PRESETS)}", option="preset")
    return PRESETS[preset]


def default_options(preset: str, sonar: str = DEFAULT_SONAR) -> dict[str, Any]:
    """Every option of a preset with its value before overrides (``--show-options``)."""
    return {**dataclasses.asdict(options_class(preset)()), "sonar": sonar,
            **dataclasses.asdict(named_sonar(sonar))}


def check_options(opt: Any, sonar: Sonar) -> None:
    positive = {"side", "radius", "ping_spacing", "grid_spacing", "group_spacing",
                "line_spacing", "per_group", "line_extent", "swath_deg", "n_beams", "reef_scale"}
    for obj in (opt, sonar):
        for f in dataclasses.fields(obj):
            v = getattr(obj, f.name)
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                if not math.isfinite(v):
                    raise fail(f.name, v, "a finite number")
                if f.name in positive and v <= 0:
                    raise fail(f.name, v, "a positive number")
                if v < 0 and f.name not in ("top", "seabed", "origin_x", "origin_y"):
                    raise fail(f.name, v, "a number >= 0")
    if 0 < sonar.tail_dof <= 2:
        raise fail("tail_dof", sonar.tail_dof, "0 (normal noise) or more than 2 degrees of freedom")
    if sonar.swath_deg >= 170:
        raise fail("swath_deg", sonar.swath_deg, "a swath below 170 deg")
    if isinstance(opt, JacketOptions):
        names = [s.strip() for s in opt.lines.split(",") if s.strip()]
        bad = [n for n in names if n not in JACKET_LINES]
        if not names or bad:
            raise fail("lines", bad[0] if bad else opt.lines,
                       f"survey lines from {', '.join(JACKET_LINES)}, comma-separated")
        if opt.top < opt.seabed + 0.5:
            raise fail("top", opt.top, f"a pile top at least 0.5 m above the seabed ({opt.seabed} m)")
    if isinstance(opt, WharfOptions):
        rakes(opt.rakes)
        if opt.top < opt.seabed + 0.5:
            raise fail("top", opt.top, f"a pile top at least 0.5 m above the seabed ({opt.seabed} m)")
    if isinstance(opt, ReefFieldOptions):
        kinds = [s.strip() for s in opt.groups.split(",") if s.strip()]
        bad = [k for k in kinds if k not in BUILTIN_DESIGNS and k != "mixed"]
        if not kinds or bad:
            raise fail("groups", bad[0] if bad else opt.groups,
                       f"reef kinds from {', '.join(BUILTIN_DESIGNS)}, mixed, comma-separated")
        most = opt.per_group * len(kinds) // 2
        if opt.close_pairs + opt.touching_pairs > most:
            raise fail("touching_pairs" if opt.touching_pairs else "close_pairs",
                       opt.touching_pairs or opt.close_pairs,
                       f"close_pairs + touching_pairs at most {most} (half the {2 * most} reefs)")


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
JACKET_LINES = ("west", "east", "south", "north", "tops")
