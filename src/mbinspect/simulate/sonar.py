"""The simulated sonar (its geometry and error model), the survey lines and the named
sonars."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError


@dataclass(frozen=True)
class Sonar:
    """Multibeam system and error model. All sigmas are 1-sigma; ``noise_scale`` scales them.

    Parameters
    ----------
    swath_deg : float
        Full swath opening angle, degrees (beams from -swath/2 to +swath/2).
    n_beams : int
        Beams per ping.
    spacing : {"equidistant", "equiangular"}
        Beam distribution across the swath.
    draft : float
        Transducer depth below the surface (m).
    range_sigma, range_sigma_rel : float
        Range noise: constant part (m) plus a fraction of the range.
    angle_sigma_deg : float
        Beam-pointing noise at nadir (deg), growing as 1/cos(beam angle).
    position_sigma, vertical_sigma : float
        Per-ping horizontal and vertical positioning noise (m): RTK, heave.
    attitude_sigma_deg : float
        Per-ping residual roll error (deg), common to every beam of the ping.
    refraction_bias_deg : float
        Systematic depression-angle error at the outermost beam (deg), growing as
        (angle / max angle)^2 toward the outer beams (sound-speed error).
    roll_amplitude_deg, pitch_amplitude_deg, heave_amplitude : float
        Vessel motion (compensated) that steers the beams.
    spike_rate, water_column_rate : float
        Fractions of soundings that are multipath spikes (long ranges) and
        water-column returns (short ranges).
    noise_scale : float
        Multiplies every noise sigma and outlier rate (1 = default).
    tail_dof : float
        Heavy tails: the range and pointing noise are Student-t with this many degrees of
        freedom, scaled so that their robust σ (1.4826 × median absolute value) is the
        sigma given; 0 (default) keeps them normal. Real shallow files show p99/σ of
        3.7–5.6 (``benchmarks/real_noise.py``); with the simulator's per-ping errors, 2.5
        gives 3.9 and 3 gives 3.5.
    speckle_db : float
        Backscatter speckle, 1σ (dB); real files show 1.3–12 dB within an angle bin.
    range_angle_growth : float
        Range noise grows off nadir by the factor 1 + growth·|sin θ| / sin 60°: the
        bottom detection worsens as the footprint lengthens (0: no growth).
    line_offset_sigma : float
        Per-line vertical offset, 1σ (m): tide, draft and heave errors that make
        overlapping strips disagree.
    refraction_sigma_deg : float
        Per-line random sound-speed error: a depression-angle bias at the outermost beam
        (deg, 1σ), drawn for each line and shaped like ``refraction_bias_deg`` (the
        across-swath "smile").
    beam_bias_sigma : float
        Per-line, per-beam range offset, 1σ (m): the stripes along track that a beam's
        own detection bias leaves.
    bs_line_sigma_db : float
        Per-line backscatter gain offset, 1σ (dB): uncalibrated levels.
    bs_angle_db : float
        Uncalibrated angular response: the stored backscatter falls by this many dB
        (× a per-line factor drawn in [0.5, 1.5]) from nadir to the outermost beam.
    """

    swath_deg: float = 120.0
    n_beams: int = 256
    spacing: str = "equidistant"
    draft: float = 0.5
    range_sigma: float = 0.01
    range_sigma_rel: float = 0.0005
    angle_sigma_deg: float = 0.03
    position_sigma: float = 0.015
    vertical_sigma: float = 0.02
    attitude_sigma_deg: float = 0.01
    refraction_bias_deg: float = 0.0
    roll_amplitude_deg: float = 2.0
    pitch_amplitude_deg: float = 1.0
    heave_amplitude: float = 0.2
    spike_rate: float = 0.001
    water_column_rate: float = 0.0005
    noise_scale: float = 1.0
    tail_dof: float = 0.0
    speckle_db: float = 2.5
    range_angle_growth: float = 0.0
    line_offset_sigma: float = 0.0
    refraction_sigma_deg: float = 0.0
    beam_bias_sigma: float = 0.0
    bs_line_sigma_db: float = 0.0
    bs_angle_db: float = 0.0

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


#: The sonar a simulation uses unless told.
DEFAULT_SONAR = "shallow"


@dataclass(frozen=True)
class SonarChoice:
    """The one simulation option that is not a field of :class:`Sonar`."""

    sonar: str = DEFAULT_SONAR  #: named sonar (SONARS) whose fields the sonar options override


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
