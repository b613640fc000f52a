"""Plan before you sail: the survey lines that will measure every spacing of a pile design to a
target 1-sigma, or give every unit of a reef plan its soundings and detect the S-44 order's
features, predicted by surveying each candidate layout in the simulator.

Examples
--------
>>> from mbinspect.piles import Design
>>> d = Design(positions={1: (0.0, 0.0), 2: (22.0, 0.0), 3: (0.0, 22.0), 4: (22.0, 22.0)})
>>> r = plan_survey(d, radius=0.75, depth=21.0, height=5.0, offsets="12.5", seeds=1, workers=1,
...                 sonar="shallow")   # doctest: +SKIP
"""

from __future__ import annotations

from .layouts import Frame, Layout, PlanLine, candidates, structure_frame
from .options import PlanOptions
from .predict import DesignPile, Trial, run_trial
from .reef_results import ReefPlanResult, ReefPrediction, UnitPrediction
from .reef_run import plan_reef_survey
from .results import PlanResult, PredictedSpacing, Prediction
from .run import design_piles, ping_rate, plan_input, plan_survey

__all__ = ["Frame", "Layout", "PlanLine", "candidates", "structure_frame", "PlanOptions", "DesignPile",
           "Trial", "run_trial", "PlanResult", "PredictedSpacing", "Prediction", "design_piles", "ping_rate",
           "plan_survey", "plan_input", "plan_reef_survey", "ReefPlanResult", "ReefPrediction",
           "UnitPrediction"]
