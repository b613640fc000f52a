"""Known piles and reefs put into a real survey, carrying the survey's own noise and shadows
(:func:`inject`); the objects and the CSV files that list them; each ping's transducer."""

from ..pings import estimate_pings, ping_origins
from .cast import inject
from .objects import InjectedPile, InjectedReef, Injection, read_pile_file, read_reef_file

__all__ = ["InjectedPile", "InjectedReef", "Injection", "estimate_pings", "inject", "ping_origins",
           "read_pile_file", "read_reef_file"]
