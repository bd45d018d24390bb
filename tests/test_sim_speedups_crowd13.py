"""B5 speed-ups of session 13 (crowd13) that claim identical results, each against the former code (the
array code of the library, kept as the reference)."""

from __future__ import annotations

import numpy as np

from kbplanner.simulation import social_force
from kbplanner.simulation.social_force import Obstacle, SocialForceParams
from kbplanner.simulation.social_force_few import same_people_terms
from kbplanner.world.footprint import Rect


def _numpy_accelerations(*args: object) -> np.ndarray:
    """social_force.accelerations by its array code (the former code for every crowd size)."""
    old = social_force.SMALL_CROWD
    social_force.SMALL_CROWD = -1
    try:
        return social_force.accelerations(*args)  # type: ignore[arg-type]
    finally:
        social_force.SMALL_CROWD = old


def test_a_few_alike_workers_one_distance_and_exponential_per_pair_are_bit_identical() -> None:
    """Workers with the same personal distance and range (the case study's): one hypot and one exp per
    pair, as the array code's two."""
    rng = np.random.default_rng(13)
    rects = [Rect(0, 0, 0.99, 0.67), Rect(0.3, 0.1, 1.5, 0.4, 0.2)]
    symmetric = 0
    for trial in range(1500):
        n = int(rng.integers(2, social_force.SMALL_CROWD + 1))
        pos = rng.uniform(0, 6, (n, 2))
        if rng.random() < 0.2:
            pos[1] = pos[0]  # two workers on one spot
        if rng.random() < 0.2:
            pos[:, 1] = 1.5  # in a row: distances of pairs with zero y offsets, signed zeros
        vel = rng.normal(0, 1, (n, 2)) * (rng.random((n, 1)) > 0.3)
        desired = rng.normal(0, 1, (n, 2)) * (rng.random((n, 1)) > 0.3)
        alike = SocialForceParams(anisotropy=float(rng.uniform(0, 1)), b_people=float(rng.uniform(0.1, 0.5)),
                                  personal_distance_m=float(rng.uniform(0.2, 0.6)))
        params = [alike if rng.random() < 0.9 else SocialForceParams(anisotropy=float(rng.uniform(0, 1)),
                                                                      comfort_distance_m=1.0)
                  for _ in range(n)]
        k = social_force.constants_of(params)
        symmetric += same_people_terms(social_force._lists(k))
        seen = None if rng.random() < 0.2 else Obstacle(
            (float(rng.uniform(0, 6)), float(rng.uniform(0, 6)), float(rng.uniform(-3, 3))),
            rects[: int(rng.integers(1, 3))])
        active = rng.random(n) > 0.2 if rng.random() < 0.3 else np.ones(n, dtype=bool)
        got = social_force.accelerations(pos, vel, desired, params, seen, active, constants=k)
        want = _numpy_accelerations(pos, vel, desired, params, seen, active)
        assert got.shape == want.shape and got.tobytes() == want.tobytes(), trial
    assert 600 < symmetric < 1500  # both ways taken
