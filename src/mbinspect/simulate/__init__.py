"""A ray-cast multibeam survey over a scene whose piles and reefs are known exactly.

Every accuracy figure mbinspect quotes is measured against this module, so it models
what makes field data hard rather than sprinkling points on shapes:

* **Geometry**: every beam of every ping is a ray from the transducer (draft below the
  surface, heave, roll and pitch steering it) across the track; the *first* surface it
  meets makes the sounding, so faces hidden from every line get no points.
* **Scene**: a seabed height field (plane, slope, sand waves, random roughness), piles
  as finite capped cylinders (radius, top elevation, tilt and tilt bearing), reefs as
  unions of oriented boxes (cross-shaped single and double layer, hollow square,
  triangular) and distractors (boulders as spheres, debris as small boxes).
* **Errors**: range noise growing with range and beam angle, beam-pointing noise growing
  as 1/cos(beam angle), both heavy-tailed, per-ping position and heave noise (RTK grade),
  residual roll per ping, per-line height offsets and refraction "smiles", per-beam range
  biases, grazing-angle dropouts, multipath spikes below the seabed and water-column
  noise. Named sonars (:data:`SONARS`) set them: ``shallow`` (the default, calibrated
  against real files), ``deep`` and the idealised ``classic``.
* **Backscatter**: by material (concrete and rock brighter than sediment), with a
  Lambertian fall-off, a near-specular peak, speckle and (uncalibrated, as stored by
  real systems) a gain and an angular fall that change from line to line; exported as ``intensity``
  = backscatter strength in dB + 100.

Coordinates are local to the scene during ray casting and shifted by the scene's
``origin`` (a projected easting/northing) on output, as a real export would be.

Examples
--------
>>> from mbinspect.simulate import simulate
>>> sim = simulate("jacket", seed=1, ping_spacing=0.5)   # a sparse, quick survey
>>> len(sim.truth["piles"])
4
>>> sim.cloud.xyz.shape[1]
3
"""

from __future__ import annotations

from .bundle import write_bundle
from .presets import PRESETS, JacketOptions, ReefFieldOptions, WharfOptions, default_options, option_fields
from .raycast import hit_objects
from .run import Simulation, simulate, simulate_lines
from .scene import LABELS, Boulder, Box, Pile, Reef, Scene, Seabed, reef_boxes
from .sonar import DEFAULT_SONAR, SONARS, Line, Sonar, SonarChoice, Survey, named_sonar
from .survey import survey
from .truth import reef_reference_rows, reef_truth, truth_spacings

__all__ = [
    "Seabed",
    "simulate_lines",
    "reef_reference_rows",
    "Pile",
    "Box",
    "Reef",
    "Boulder",
    "Scene",
    "Sonar",
    "SonarChoice",
    "Line",
    "Survey",
    "Simulation",
    "JacketOptions",
    "ReefFieldOptions",
    "PRESETS",
    "SONARS",
    "named_sonar",
    "default_options",
    "reef_boxes",
    "reef_truth",
    "survey",
    "simulate",
    "LABELS",
    "WharfOptions",
    "option_fields",
    "hit_objects",
    "DEFAULT_SONAR",
    "truth_spacings",
    "write_bundle",
]




# ---------------------------------------------------------------------------- scene














# ---------------------------------------------------------------------------- survey








# ---------------------------------------------------------------------------- ray casting



































# ---------------------------------------------------------------------------- reefs








# ---------------------------------------------------------------------------- presets





























































