"""Survey after survey: two surveys of one reef field compared object by object.

:func:`compare_surveys` registers the after survey on the before survey's seabed away from
the objects (vertical offset, plan shift, a small rotation, each with its 1-sigma), matches
the reefs one to one, and gives each its displacement, turn, settlement, height, tilt, how
it rests and the scour round it, every change with its 95 % level of detection; a change
inside it is "no detectable change".

Examples
--------
>>> from mbinspect.change import ChangeOptions
>>> ChangeOptions().max_move
3.0
"""

from .grid import Grid, median_grid
from .match import match_objects
from .options import ChangeOptions
from .register import Registration, register
from .results import MEASURES, STATUSES, ChangeResult, ObjectChange
from .run import compare_surveys

__all__ = ["compare_surveys", "ChangeOptions", "ChangeResult", "ObjectChange", "Registration", "register",
           "Grid", "median_grid", "match_objects", "MEASURES", "STATUSES"]
