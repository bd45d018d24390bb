"""B5 navigation under monitoring (reverse12/13): the loaded base backs out of the storage only as far as
it must before it turns round and drives forwards, measured on the run's trajectory by
:mod:`kbplanner.analysis.reverse_driving` (which ``benchmarks/reverse_driving.py`` prints)."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import pytest

from kbplanner.analysis.reverse_driving import moves, reverse_of
from kbplanner.simulation.executor import INSTALLED, SimulationResult, simulate
from sim_project_factory import PICKUP, load_sim_case

SEED = 3
HEAD = ["t_s", "x", "y", "yaw", "carried"]


def _write_run(run: Path, rows: list[tuple[float, float, float, float, str]]) -> Path:
    run.mkdir()
    with (run / "trajectories.csv").open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(HEAD)
        w.writerows(rows)
    return run


def test_the_measure_counts_travel_against_the_yaw_as_backwards(tmp_path: Path) -> None:
    # facing +x: 1 m forwards, 0.5 m backwards carrying, 0.4 m sideways (not backwards), then 0.3 m back
    rows = [(0.0, 0.0, 0.0, 0.0, ""), (1.0, 1.0, 0.0, 0.0, ""), (2.0, 1.0, 0.0, 0.0, "e1"),
            (3.0, 0.5, 0.0, 0.0, "e1"), (4.0, 0.5, 0.4, 0.0, ""), (5.0, 0.5, 0.4, math.pi, ""),
            (6.0, 0.8, 0.4, math.pi, "")]
    got = reverse_of(_write_run(tmp_path / "run", rows))
    assert got["backward_m"] == pytest.approx(0.8)
    assert got["backward_carrying_m"] == pytest.approx(0.5)
    assert got["driven_m"] == pytest.approx(2.2)


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> SimulationResult:
    case = load_sim_case(tmp_path_factory.mktemp("simproj"), seed=SEED, high_panel=False)
    return simulate(case.project, case.refined, out_dir=tmp_path_factory.mktemp("runs") / "a", seed=SEED,
                    world=case.world, grid=case.grid)


def test_under_monitoring_the_loaded_base_backs_out_of_the_storage_less_than_a_straight_reverse(
        run: SimulationResult) -> None:
    installed = [e for e in run.elements if e.outcome == INSTALLED]
    assert len(installed) == 2
    with (run.out_dir / "trajectories.csv").open(newline="") as fh:
        back = [m for m in moves(csv.DictReader(fh)) if m.backward and m.row["carried"]]
    assert back  # the pickup faces the stack: the base has to back away from it with the panel
    for m in back:  # only there: never through the door or towards the install location
        assert math.hypot(float(m.row["x"]) - PICKUP[0], float(m.row["y"]) - PICKUP[1]) < 1.0, m
    # it turns round as soon as the panel (2.4 m across) lets it: before reverse12 it reversed a straight
    # 1.0 m out of the storage with each panel
    assert sum(m.length_m for m in back) < 0.8 * len(installed)
    assert reverse_of(run.out_dir)["backward_carrying_m"] == pytest.approx(sum(m.length_m for m in back),
                                                                           abs=0.01)
