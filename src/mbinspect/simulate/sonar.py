"""The simulated sonar (its geometry and error model), the survey lines and the named
sonars."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ..beam import Beam
from ..checks import fail, non_negative
from ..errors import ParameterError
from ..options import CHOICES, Options, option


def _tail_dof(name: str, value: float) -> float:
    """0 (normal noise) or more than 2 degrees of freedom."""
    value = non_negative(name, value)
    if 0 < value <= 2:
        raise fail(name, value, "0 (normal noise) or more than 2 degrees of freedom")
    return value



@dataclass(frozen=True)
class Sonar(Beam):
    """Multibeam system and error model. All sigmas are 1-sigma; ``noise_scale`` scales them.

    Every field is an option (:mod:`mbinspect.options`): its unit, default and check are
    written once here and the command line offers each as a flag. ``tail_dof``: the range
    and pointing noise are Student-t with this many degrees of freedom, scaled so that their
    robust σ (1.4826 × median absolute value) is the sigma given; 0 keeps them normal. Real
    shallow files show p99/σ of 3.7–5.6 (``benchmarks/real_noise.py``); with the simulator's
    per-ping errors, 2.5 gives 3.9 and 3 gives 3.5. ``range_angle_growth``: the range noise
    grows off nadir by the factor 1 + growth·|sin θ| / sin 60° (the bottom detection worsens
    as the footprint lengthens). ``refraction_bias_deg`` and ``refraction_sigma_deg`` grow
    as (angle / max angle)² toward the outer beams (the across-swath "smile"). The beam's
    width and bottom detection are the fields of :class:`~mbinspect.simulate.beam.Beam`
    (one thin ray per beam unless a width is given).
    """

    swath_deg: float = option(120.0, unit="deg", check="positive",
                              help="full swath opening angle (beams from -swath/2 to +swath/2)")
    n_beams: int = option(256, help="beams per ping", check="count")
    spacing: str = option("equidistant", choices="beam_spacing", help="beam distribution across the swath")
    draft: float = option(0.5, unit="m", help="transducer depth below the surface", check="non_negative")
    range_sigma: float = option(0.01, unit="m", help="range noise, constant part", check="non_negative")
    range_sigma_rel: float = option(0.0005, check="non_negative", help="range noise, share of the range")
    angle_sigma_deg: float = option(0.03, unit="deg", check="non_negative",
                                    help="beam-pointing noise at nadir, growing as 1/cos(beam angle)")
    position_sigma: float = option(0.015, unit="m", check="non_negative",
                                   help="per-ping horizontal positioning noise (RTK)")
    vertical_sigma: float = option(0.02, unit="m", check="non_negative",
                                   help="per-ping vertical positioning noise (heave)")
    attitude_sigma_deg: float = option(0.01, unit="deg", check="non_negative",
                                       help="per-ping residual roll error, common to every beam of the ping")
    refraction_bias_deg: float = option(0.0, unit="deg", check="non_negative",
                                        help="systematic depression-angle error at the outermost beam")
    roll_amplitude_deg: float = option(2.0, unit="deg", check="non_negative",
                                       help="vessel roll (compensated) that steers the beams")
    pitch_amplitude_deg: float = option(1.0, unit="deg", check="non_negative",
                                        help="vessel pitch (compensated) that steers the beams")
    heave_amplitude: float = option(0.2, unit="m", help="vessel heave (compensated)", check="non_negative")
    motion_phase: str = option("random", choices="motion_phase",
                               help="phase of the roll, pitch and heave at each line's start: drawn per "
                                    "line from the seed (random), or the same on every line of every survey "
                                    "(fixed)")
    spike_rate: float = option(0.001, check="non_negative",
                               help="share of soundings that are multipath spikes (long ranges)")
    water_column_rate: float = option(0.0005, check="non_negative",
                                      help="share of soundings that are water-column returns (short ranges)")
    noise_scale: float = option(1.0, check="non_negative",
                                help="multiplies every noise sigma and outlier rate (1: as given)")
    tail_dof: float = option(0.0, check=_tail_dof,
                             help="Student-t degrees of freedom of the range and pointing noise (0: normal)")
    speckle_db: float = option(2.5, unit="dB", check="non_negative",
                               help="backscatter speckle (real files: 1.3-12 dB within an angle bin)")
    range_angle_growth: float = option(0.0, check="non_negative",
                                       help="growth of the range noise off nadir (0: none)")
    line_offset_sigma: float = option(0.0, unit="m", check="non_negative",
                                      help="per-line vertical offset: tide, draft and heave errors")
    refraction_sigma_deg: float = option(0.0, unit="deg", check="non_negative",
                                         help="per-line sound-speed error at the outermost beam")
    beam_bias_sigma: float = option(0.0, unit="m", check="non_negative",
                                    help="per-line, per-beam range offset (stripes along track)")
    bs_line_sigma_db: float = option(0.0, unit="dB", check="non_negative",
                                     help="per-line backscatter gain offset (uncalibrated levels)")
    bs_angle_db: float = option(0.0, unit="dB", check="non_negative",
                                help="fall of the stored backscatter from nadir to the outermost beam")
    tide_range: float = option(0.0, unit="m", check="non_negative",
                               help="tide range, low to high water (a semi-diurnal cosine); the soundings' "
                                    "heights are from the water level at each ping, as KMALL and .all give "
                                    "them")
    tide_mean: float = option(0.0, unit="m", check="finite", help="mean water level above chart datum")
    start_time: float = option(1780300800.0, unit="s", check="finite",
                               help="UTC time of the first ping, seconds since 1970 (2026-06-01T08:00Z)")
    turn_s: float = option(120.0, unit="s", check="non_negative", help="time between two lines (the turn)")

    def tide(self, utc: np.ndarray) -> np.ndarray:
        """The water level (m above chart datum) at UTC times (s since 1970): a cosine of
        12.42 h, high water at ``start_time``."""
        return self.tide_mean + self.tide_range / 2 * np.cos(2 * np.pi * (np.asarray(utc) - self.start_time)
                                                             / TIDE_PERIOD_S)

    def check_together(self) -> None:
        """A swath under 170 degrees."""
        if self.swath_deg >= 170:
            raise fail("swath_deg", self.swath_deg, "a swath below 170 deg")

    def beam_angles(self) -> np.ndarray:
        """Nominal beam angles (radians, + to starboard), shape (n_beams,)."""
        half = math.radians(self.swath_deg / 2.0)
        if self.spacing == "equiangular":
            return np.linspace(-half, half, self.n_beams)
        if self.spacing == "equidistant":
            return np.arctan(np.linspace(-math.tan(half), math.tan(half), self.n_beams))
        raise ParameterError(
            f"spacing: {self.spacing!r} is not 'equidistant' or 'equiangular'"
        )


@dataclass(frozen=True)
class Line:
    """A survey line: a polyline of local (x, y) vertices sailed at ``ping_spacing``."""

    vertices: tuple[tuple[float, float], ...]
    ping_spacing: float = 0.1
    speed: float = 2.0

    def pings(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Ping positions (P, 2), headings as unit vectors (P, 2), along-line distance (P,)."""
        v = np.asarray(self.vertices, dtype=np.float64)
        seg = np.diff(v, axis=0)
        seglen = np.hypot(seg[:, 0], seg[:, 1])
        cum = np.concatenate([[0.0], np.cumsum(seglen)])
        s = np.arange(0.0, cum[-1] + 1e-9, self.ping_spacing)
        k = np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(seg) - 1)
        frac = (s - cum[k]) / np.maximum(seglen[k], 1e-12)
        pos = v[k] + frac[:, None] * seg[k]
        heading = seg[k] / np.maximum(seglen[k], 1e-12)[:, None]
        return pos, heading, s


@dataclass(frozen=True)
class Survey:
    """The lines sailed and the system used."""

    lines: tuple[Line, ...]
    sonar: Sonar = Sonar()

    def estimated_soundings(self) -> int:
        """Beams times pings over every line: the most soundings the survey can make."""
        pings = 0
        for line in self.lines:
            v = np.asarray(line.vertices, np.float64)
            length = float(np.hypot(*np.diff(v, axis=0).T).sum())
            pings += int(length / line.ping_spacing) + 1
        return pings * self.sonar.n_beams


#: The simulated tide's period (s): the principal lunar semi-diurnal, 12.42 h.
TIDE_PERIOD_S = 12.42 * 3600.0

#: Named sonars: the error model a simulation starts from (its fields stay overridable).
#: ``shallow`` (the default) is calibrated against the real files of 4–58 m in
#: ``benchmarks/real_noise.py``; ``classic`` is the idealised model the first studies used.
SONARS: dict[str, Sonar] = {
    # a 400 kHz shallow-water system at 10-30 m: heavy tails, noise growing off nadir,
    # strips that disagree, uncalibrated backscatter
    "shallow": Sonar(angle_sigma_deg=0.02, tail_dof=3.5, speckle_db=5.0, range_angle_growth=1.2,
                     line_offset_sigma=0.03,
                     refraction_sigma_deg=0.03, beam_bias_sigma=0.003, bs_line_sigma_db=3.0,
                     bs_angle_db=10.0),
    # a 30 kHz deep-water system at 100-1000 m: wider beams, coarser detection, no RTK
    "deep": Sonar(swath_deg=130.0, n_beams=288, range_sigma=0.015, range_sigma_rel=0.0001,
                  angle_sigma_deg=0.015, position_sigma=0.05, vertical_sigma=0.025,
                  tail_dof=3.5, speckle_db=5.0, range_angle_growth=0.8, line_offset_sigma=0.05,
                  refraction_sigma_deg=0.03, beam_bias_sigma=0.005, bs_line_sigma_db=3.0,
                  bs_angle_db=10.0),
    # the first studies' idealised model: normal noise, no line errors, calibrated backscatter
    "classic": Sonar(),
}

# the same systems with their beams as cones (a 400 kHz shallow system's 1° x 1°, a deep
# system's 2° x 2°) and the makers' detection: amplitude near nadir, phase outside
SONARS["shallow-beam"] = dataclasses.replace(SONARS["shallow"], beam_across_deg=1.0, beam_along_deg=1.0)
SONARS["deep-beam"] = dataclasses.replace(SONARS["deep"], beam_across_deg=2.0, beam_along_deg=2.0)

CHOICES["sonar"] = tuple(SONARS)

#: The sonar a simulation uses unless told.
DEFAULT_SONAR = "shallow"


@dataclass(frozen=True)
class SonarChoice(Options):
    """The one simulation option that is not a field of :class:`Sonar`."""

    sonar: str = option(DEFAULT_SONAR, choices="sonar",
                        help="named sonar whose fields the sonar options override")


def named_sonar(name: str) -> Sonar:
    """The :class:`Sonar` of a name in :data:`SONARS`.

    Raises
    ------
    ParameterError
        An unknown name.

    Examples
    --------
    >>> named_sonar("classic").tail_dof
    0.0
    """
    if name not in SONARS:
        raise ParameterError(f"sonar: {name!r}; expected one of {', '.join(SONARS)}", option="sonar")
    return SONARS[name]
