"""Shared fixtures: small simulated surveys whose truth is known exactly."""

from __future__ import annotations

import pytest

from mbinspect.simulate import Simulation, simulate


@pytest.fixture(scope="session")
def jacket_small() -> Simulation:
    """The jacket preset at a third of its ping density (about 740 k soundings)."""
    return simulate("jacket", seed=11, ping_spacing=0.15)


@pytest.fixture(scope="session")
def jacket_exact() -> Simulation:
    """A noise-free, outlier-free sparse jacket survey: every sounding is on a surface."""
    return simulate("jacket", seed=5, ping_spacing=0.6, noise_scale=0.0)


@pytest.fixture(scope="session")
def reef_small() -> Simulation:
    """Two reef groups with close and touching pairs (about 120 k soundings)."""
    return simulate("reef-field", seed=3, groups="cross2,cross1", close_pairs=3,
                    touching_pairs=1, ping_spacing=0.6)
