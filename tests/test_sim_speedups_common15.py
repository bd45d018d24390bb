"""B5 speed-ups of session 15 (common15) that claim identical results, each against the former code (kept
here as the reference)."""

from __future__ import annotations

import math

import numpy as np

from kbplanner.simulation import base_trajectory
from kbplanner.simulation.base_trajectory import _rest_to_rest, time_parameterize
from kbplanner.world.footprint import ConfigurationSpace, Footprint, Rect
from kbplanner.world.occupancy import OccupancyGrid


def _former_passes(vlim: np.ndarray, two_a_ds: list[float]) -> list[float]:
    """The former forward and backward passes of base_trajectory._profile, step by step."""
    n = len(vlim)
    vl = vlim.tolist()
    vv = [0.0] * n
    for i in range(n - 1):
        vv[i + 1] = min(vl[i + 1], math.sqrt(vv[i] * vv[i] + two_a_ds[i]))
    vv[-1] = 0.0
    for i in range(n - 2, -1, -1):
        vv[i] = min(vv[i], math.sqrt(vv[i + 1] * vv[i + 1] + two_a_ds[i]))
    return vv


def _bits(values: list[float]) -> bytes:
    return np.asarray(values, dtype=np.float64).tobytes()


def test_the_rest_to_rest_passes_are_bit_identical_to_the_step_by_step_loops() -> None:
    """Plateaus, rises, falls, dips to zero, ties with the square roots, steps of one size and of many."""
    rng = np.random.default_rng(15)
    for trial in range(600):
        n = int(rng.integers(3, 400))
        kind = trial % 4
        if kind == 0:  # plateaus (a top speed, slower stretches)
            vlim = np.repeat(rng.choice([0.2, 0.35, 0.5], size=n // 10 + 1), 10)[:n].astype(np.float64)
        elif kind == 1:  # smooth limits (curves): rising and falling every step
            vlim = 0.3 + 0.2 * np.sin(np.linspace(0, rng.uniform(1, 30), n)) ** 2
        elif kind == 2:  # anything, zeros included
            vlim = rng.uniform(0, 1, n) * (rng.random(n) > 0.05)
        else:  # the top speed but here and there a limit that equals a square root of the pass
            vlim = np.full(n, 0.5)
        a = rng.uniform(0.05, 1.0)
        ds = rng.uniform(0.001, 0.02)
        one_size = rng.random() < 0.5
        steps = np.full(n - 1, 2.0 * a * ds) if one_size else 2.0 * rng.uniform(0.05, 1.0, n - 1) * ds
        two_a_ds = steps.tolist()
        if kind == 3:
            fwd = _former_passes(np.full(n, np.inf), two_a_ds)  # the square roots the pass takes
            for k in rng.integers(1, n - 1, size=5).tolist():
                vlim[k] = fwd[k]
        got, want = _rest_to_rest(vlim, two_a_ds), _former_passes(vlim, two_a_ds)
        assert _bits(got) == _bits(want), trial


def test_a_trajectory_is_the_same_as_with_the_former_passes_and_wrap() -> None:
    """time_parameterize with the passes against the former loops (swapped in)."""
    rng = np.random.default_rng(3)
    limits = {"max_speed_mps": 0.5, "max_yaw_rate_rps": 1.0, "max_accel_mps2": 0.5, "max_yaw_accel_rps2": 2.0}
    former = base_trajectory._rest_to_rest
    for trial in range(20):
        pts = np.cumsum(rng.uniform(-2, 2, (int(rng.integers(2, 8)), 2)), axis=0)
        yaws = rng.uniform(-math.pi, math.pi, len(pts))
        poses = [(float(x), float(y), float(t)) for (x, y), t in zip(pts, yaws, strict=True)]
        got = time_parameterize(poses, **limits)
        base_trajectory._rest_to_rest = _former_passes  # type: ignore[assignment]
        try:
            want = time_parameterize(poses, **limits)
        finally:
            base_trajectory._rest_to_rest = former
        assert got.t_s == want.t_s, trial
        assert _bits([c for p in got.poses for c in p]) == _bits([c for p in want.poses for c in p]), trial


def test_a_path_timed_again_is_the_kept_trajectory_and_the_same_as_timed_anew() -> None:
    """time_parameterize keeps what it timed by the poses' bits, the space's identity and the limits."""
    occ = np.zeros((80, 80), dtype=bool)
    occ[[0, -1], :] = True
    occ[:, [0, -1]] = True
    foot = Footprint((Rect(0.0, 0.0, 0.99, 0.67),), name="husky")
    space = ConfigurationSpace.build(OccupancyGrid(occ, origin=(0.0, 0.0), resolution=0.05), foot, 72)
    poses = [(1.0, 1.0, 0.0), (3.0, 1.0, 0.0), (3.0, 1.0, math.pi / 2), (3.0, 3.0, math.pi / 2)]
    limits = (0.5, 1.0, 0.5, 2.0, 10.0)
    base_trajectory._TIMED.clear()
    first = time_parameterize(list(poses), *limits, space=space)
    again = time_parameterize([tuple(p) for p in poses], *limits, space=space)
    assert again is first  # kept
    base_trajectory._TIMED.clear()
    anew = time_parameterize(poses, *limits, space=space)
    assert anew is not first and anew == first
    # another space, other limits, a signed zero, numpy scalars: not the kept one
    other = ConfigurationSpace.build(OccupancyGrid(occ, origin=(0.0, 0.0), resolution=0.05), foot, 72)
    assert time_parameterize(poses, *limits, space=other) is not anew
    assert time_parameterize(poses, 0.4, 1.0, 0.5, 2.0, 10.0, space=space) is not anew
    signed = [(1.0, 1.0, -0.0), *poses[1:]]
    assert time_parameterize(signed, *limits, space=space) is not anew
    scalars = [tuple(np.float64(v) for v in p) for p in poses]
    assert time_parameterize(scalars, *limits, space=space) is not anew  # type: ignore[arg-type]
    assert len(base_trajectory._TIMED) <= base_trajectory.TIMED_KEPT
