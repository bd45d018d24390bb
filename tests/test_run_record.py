"""Analysis of a run directory: durations and proximity from hand-made records with known answers."""

from __future__ import annotations

from pathlib import Path

import pytest

from kbplanner.analysis.run_record import RunRecord
from kbplanner.core.errors import InputFileError
from run_factory import write_run


def test_distances_use_the_footprint_and_the_carried_element_in_its_carry_mode(tmp_path: Path) -> None:
    write_run(tmp_path)
    rec = RunRecord.load(tmp_path)
    prox = rec.proximity(threshold_m=1.0, worker_radius_m=0.0)
    (w,) = prox.workers
    # Worker at (0, 1.8). Empty-handed: the base's side is at y = 0.3, so 1.5 m. Panel carried across
    # (half-width 1.2 m): 0.6 m. Narrow (panel along x, half-width 0.1 m): the base is nearer, 1.5 m.
    # Facing +y, the base's half-length 0.5 m points at the worker: 1.3 m.
    assert w.distance_m.tolist() == pytest.approx([1.5, 0.6, 0.6, 1.5, 1.3])
    assert w.min_distance_m == pytest.approx(0.6) and w.t_min_s == 1.0
    assert [(i.start_s, i.end_s) for i in w.below_threshold] == [(1.0, 3.0)]
    assert w.time_below_threshold_s == pytest.approx(2.0)
    # The robot does not move, so S_p is the standing value 1.6 * 0.14 + 1.08 + 0.1 = 1.404 m (the
    # simulation's defaults; the record has no safety.ssm): below at 0.6, 0.6 and 1.3 m.
    assert w.time_below_separation_s == pytest.approx(3.0)
    assert prox.time_below_separation_s == pytest.approx(3.0)
    assert prox.time_below_threshold_s == pytest.approx(2.0)
    assert prox.min_distance_m == pytest.approx(0.6)


def test_the_worker_body_radius_is_subtracted(tmp_path: Path) -> None:
    write_run(tmp_path)
    prox = RunRecord.load(tmp_path).proximity(worker_radius_m=0.25)
    assert prox.workers[0].min_distance_m == pytest.approx(0.35)


def test_durations_per_action_element_and_total(tmp_path: Path) -> None:
    write_run(tmp_path)
    rec = RunRecord.load(tmp_path)
    d = rec.durations()
    assert d.total_s == 4.0 and d.installed == 1
    assert d.first_element_s == 4.0 and d.mean_per_element_s == 4.0
    assert d.per_action_kind() == {"navigate": 1.0, "install": 3.0}
    assert rec.event_positions("rotate_to_narrow") == [(3.0, 0.0, 0.0)]


def test_a_directory_without_a_run_is_a_clear_error(tmp_path: Path) -> None:
    with pytest.raises(InputFileError, match="missing file of a simulation run"):
        RunRecord.load(tmp_path)
