"""The plan shift refined on the objects that kept their place (issue 29): its error covered
by its sigma, and the cases where the objects must not be used."""

from __future__ import annotations

import math

import numpy as np

from mbinspect.change.register import IDENTITY, Registration
from mbinspect.change.tie import MIN_TIES, PILE_TIES, tie_to_objects


def _seabed(dx: float, dy: float, sigma: float) -> Registration:
    cov = np.diag([sigma**2, sigma**2, 0.002**2, 1e-8])
    return Registration(dx, dy, 0.0, 0.0, sigma, sigma, 0.002, 0.01, (50.0, 50.0), 1e4, 10000, 0.02, 20, "",
                        cov)


def _survey(rng: np.random.Generator, true: np.ndarray, seabed: Registration, n: int, moved: int,
            noise: float = 0.05) -> tuple[np.ndarray, np.ndarray, list[tuple[int, int]]]:
    """Before positions, and the after ones (true shift applied, ``moved`` units moved up
    to 2 m, each centre with ``noise`` per survey) carried back by the seabed's shift."""
    b = rng.uniform(0, 100, (n, 2))
    a = b + true + rng.normal(0, noise * math.sqrt(2), (n, 2))
    a[:moved] += rng.uniform(0.3, 2.0, (moved, 2)) * rng.choice([-1, 1], (moved, 2))
    carried = a - [seabed.dx, seabed.dy]
    return b, carried, [(k, k) for k in range(n)]


def test_the_refined_shift_is_covered_by_its_sigma():
    rng = np.random.default_rng(4)
    true = np.array([0.31, -0.22])
    errors, sigmas, seabed_errors, ties = [], [], [], []
    for _ in range(200):
        sigma = 0.04
        seabed = _seabed(*(true + rng.normal(0, sigma, 2)), sigma)
        b, a, pairs = _survey(rng, true, seabed, n=60, moved=18)
        tied = tie_to_objects(seabed, b, a, pairs)
        ties.append(tied.ties)
        errors.append([tied.dx - true[0], tied.dy - true[1]])
        sigmas.append([tied.sigma_dx, tied.sigma_dy])
        seabed_errors.append([seabed.dx - true[0], seabed.dy - true[1]])
    # of the 42 unmoved units 40-42 are used in most draws; a seabed 3 sigma off makes the
    # units' shift disagree with it, and the seabed's then stands (1 draw in 200 here)
    used = np.array(ties)
    assert np.mean(used == 0) <= 0.03 and np.min(used[used > 0]) >= 30
    e, s = np.array(errors), np.array(sigmas)
    within = np.mean(np.abs(e) <= 2 * s)
    assert 0.9 <= within <= 0.99, within
    # the 42 unmoved units' centres (7 cm apart in pairs) hold the shift to about a centimetre,
    # where the seabed held it to 4 cm
    assert np.sqrt(np.mean(e**2)) < 0.4 * np.sqrt(np.mean(np.array(seabed_errors) ** 2))
    assert np.sqrt(np.mean(e**2)) < 0.015


def test_units_that_moved_together_beyond_the_seabed_are_their_own_move():
    rng = np.random.default_rng(5)
    seabed = _seabed(0.30, -0.20, 0.02)
    b, a, pairs = _survey(rng, np.array([0.30, -0.20]), seabed, n=30, moved=0, noise=0.02)
    a += [0.4, 0.0]  # every unit slid 0.4 m east: twenty seabed sigmas
    tied = tie_to_objects(seabed, b, a, pairs)
    assert (tied.dx, tied.dy, tied.ties) == (seabed.dx, seabed.dy, 0)
    assert "moved together" in tied.note and "+0.397" in tied.note


def test_too_few_or_a_minority_of_unmoved_units_leave_the_seabed_shift():
    rng = np.random.default_rng(6)
    seabed = _seabed(0.1, 0.1, 0.04)
    b, a, pairs = _survey(rng, np.array([0.1, 0.1]), seabed, n=MIN_TIES - 1, moved=0)
    few = tie_to_objects(seabed, b, a, pairs)
    assert few.dx == seabed.dx and few.ties == 0 and "too few" in few.note
    b, a, pairs = _survey(rng, np.array([0.1, 0.1]), seabed, n=20, moved=12)
    most_moved = tie_to_objects(seabed, b, a, pairs)
    assert most_moved.dx == seabed.dx and most_moved.ties == 0
    # no seabed to check them against: the objects are never the only registration
    assert tie_to_objects(IDENTITY, b, a + 0.2, pairs) is IDENTITY


def test_a_tied_registration_reads_back():
    rng = np.random.default_rng(7)
    seabed = _seabed(0.2, 0.1, 0.04)
    b, a, pairs = _survey(rng, np.array([0.22, 0.08]), seabed, n=20, moved=2)
    tied = tie_to_objects(seabed, b, a, pairs)
    back = Registration.from_dict(tied.to_dict())
    assert back.ties == tied.ties >= 15 and back.sigma_dx == tied.sigma_dx
    old = tied.to_dict()
    del old["ties"]  # a change.json written before the ties were kept
    assert Registration.from_dict(old).ties == 0


def test_three_of_a_jackets_four_piles_that_kept_their_place_tie_the_shift():
    # a jacket's four top centres agree to millimetres: one survey's seabed along one line held
    # the shift to 46 mm on the real XTF, where its unmoved piles hold it to about a centimetre
    rng = np.random.default_rng(8)
    true = np.array([0.2, -0.1])
    errors, seabed_errors, ties = [], [], []
    for _ in range(100):
        seabed = _seabed(*(true + rng.normal(0, 0.04, 2)), 0.04)
        b, a, pairs = _survey(rng, true, seabed, n=4, moved=1, noise=0.005)
        tied = tie_to_objects(seabed, b, a, pairs, least=PILE_TIES, floor=0.005 * math.sqrt(2))
        ties.append(tied.ties)
        errors.append([tied.dx - true[0], tied.dy - true[1]])
        seabed_errors.append([seabed.dx - true[0], seabed.dy - true[1]])
    assert set(ties) <= {0, 3} and np.mean(np.array(ties) == 3) >= 0.9  # never the moved pile
    e = np.array(errors)
    assert np.sqrt(np.mean(e**2)) < 0.5 * np.sqrt(np.mean(np.array(seabed_errors) ** 2))
    # two of four kept together are no majority: the seabed's shift stands
    b, a, pairs = _survey(rng, true, seabed, n=4, moved=2, noise=0.005)
    assert tie_to_objects(seabed, b, a, pairs, least=PILE_TIES, floor=0.007).ties == 0
