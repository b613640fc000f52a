"""The options of :func:`~mbinspect.change.compare_surveys`, as data."""

from __future__ import annotations

from dataclasses import dataclass

from ..options import Options, option
from ..scour import REACH

__all__ = ["ChangeOptions"]


@dataclass(frozen=True)
class ChangeOptions(Options):
    """Options of :func:`~mbinspect.change.compare_surveys`; each is checked on creation.

    Examples
    --------
    >>> ChangeOptions().cell
    1.0
    >>> ChangeOptions(max_move=-1)
    Traceback (most recent call last):
    ...
    mbinspect.errors.ParameterError: max_move: -1; expected a positive finite number
    """

    cell: float = option(1.0, unit="m", check="positive",
                         help="the seabed grid cell the surveys are registered on")
    exclude_buffer: float = option(4.0, unit="m", check="non_negative",
                                   help="seabed this near an object (either survey) is left out of the "
                                        "registration: it may have moved or scoured")
    max_move: float = option(3.0, unit="m", check="positive",
                             help="the farthest a unit may have moved and still be matched to itself")
    position_sigma: float = option(0.05, unit="m", check="positive",
                                   help="a reef centre's 1-sigma in each survey (the studies: 2-5 cm)")
    bearing_sigma_deg: float = option(1.0, unit="deg", check="positive",
                                      help="a fitted design's bearing 1-sigma in each survey (a result "
                                           "told the beam adds its footprint's share)")
    scour_reach: float = option(REACH, unit="m", check="positive",
                                help="how far from a unit's centre the seabed is searched for scour")
    scour_cell: float = option(0.5, unit="m", check="positive",
                               help="the difference map's cell, on which scour is measured")
    inner_angle_deg: float = option(
        45.0, unit="deg", check="positive",
        help="where beam angles are known, soundings farther off nadir are left out of the registration "
             "(a line's sound-speed error bends its outer beams), unless that leaves the plan shift half "
             "again as uncertain as every beam does; 90 reads every beam")
    level_lines: bool = option(True, help="where pings and lines are known, level each survey's pings "
                                          "against the others of their line, then its lines against each "
                                          "other, before gridding (heave, tide or draft errors leave steps)")
    tie_objects: bool = option(True, help="refine the plan shift on the matched objects that kept their "
                                          "place (a majority, at least 5, agreeing with the seabed's shift "
                                          "within 3 sigma); off: the seabed's shift alone")
    rotation: bool = option(True, help="estimate a small rotation between the surveys where the seabed "
                                       "holds it")
