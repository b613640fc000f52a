"""The software version, recorded in every result's ``parameters``."""

__version__ = "0.1.0"
