"""Analysis of a run directory: durations and proximity from hand-made records with known answers."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from kbplanner.errors import InputFileError
from kbplanner.run_record import RunRecord


def _write_run(d: Path) -> None:
    d.mkdir(parents=True, exist_ok=True)
    # Robot at the origin facing +x for 4 s, then at (0, 0) facing +y; it carries F01 in the normal mode
    # (a 0.2 m deep, 2.4 m wide panel across it) from t = 1 to t = 3.
    rows = ["t_s,x,y,yaw,q1,carried,carry_mode,step,carpenter-1_x,carpenter-1_y"]
    spec = [
        (0, 0.0, "", ""),
        (1, 0.0, "F01", "normal"),
        (2, 0.0, "F01", "normal"),
        (3, 0.0, "F01", "narrow"),
        (4, 1.5707963, "", ""),
    ]
    for t, yaw, carried, mode in spec:
        rows.append(f"{t:.2f},0.0,0.0,{yaw},0.0,{carried},{mode},1,0.0,1.8")
    (d / "trajectories.csv").write_text("\n".join(rows) + "\n")
    (d / "events.jsonl").write_text(
        json.dumps(
            {
                "t_s": 3.0,
                "kind": "rotate_to_narrow",
                "step": 3,
                "element": "F01",
                "action": "a",
                "details": {},
            }
        )
        + "\n"
    )
    (d / "footprints.json").write_text(
        json.dumps(
            {
                "robot": [{"cx": 0.0, "cy": 0.0, "length": 1.0, "width": 0.6, "yaw": 0.0}],
                "elements": {
                    "F01": {
                        "normal": {"cx": 0.0, "cy": 0.0, "length": 0.2, "width": 2.4, "yaw": 0.0},
                        "narrow": {"cx": 0.0, "cy": 0.0, "length": 2.4, "width": 0.2, "yaw": 0.0},
                    }
                },
            }
        )
    )
    (d / "metrics.json").write_text(
        json.dumps(
            {
                "totals": {"sim_time_s": 4.0, "installed": 1},
                "per_element": [
                    {
                        "label": "F01",
                        "global_id": "F01",
                        "outcome": "installed",
                        "reason": None,
                        "start_s": 0.0,
                        "end_s": 4.0,
                        "duration_s": 4.0,
                        "steps": [
                            {
                                "action": "navigate",
                                "skill": "NV-1",
                                "outcome": "succeeded",
                                "reason": None,
                                "start_s": 0.0,
                                "end_s": 1.0,
                                "duration_s": 1.0,
                            },
                            {
                                "action": "install",
                                "skill": "MM-R-1",
                                "outcome": "succeeded",
                                "reason": None,
                                "start_s": 1.0,
                                "end_s": 4.0,
                                "duration_s": 3.0,
                            },
                        ],
                    }
                ],
            }
        )
    )
    (d / "manifest.json").write_text(json.dumps({"scenario": "test"}))


def test_distances_use_the_footprint_and_the_carried_element_in_its_carry_mode(tmp_path: Path) -> None:
    _write_run(tmp_path)
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
    # The robot does not move, so S_p is the standing value 2.14 m: always below.
    assert w.time_below_separation_s == pytest.approx(5.0)
    assert prox.min_distance_m == pytest.approx(0.6)


def test_the_worker_body_radius_is_subtracted(tmp_path: Path) -> None:
    _write_run(tmp_path)
    prox = RunRecord.load(tmp_path).proximity(worker_radius_m=0.25)
    assert prox.workers[0].min_distance_m == pytest.approx(0.35)


def test_durations_per_action_element_and_total(tmp_path: Path) -> None:
    _write_run(tmp_path)
    rec = RunRecord.load(tmp_path)
    d = rec.durations()
    assert d.total_s == 4.0 and d.installed == 1
    assert d.first_element_s == 4.0 and d.mean_per_element_s == 4.0
    assert d.per_action_kind() == {"navigate": 1.0, "install": 3.0}
    assert rec.event_positions("rotate_to_narrow") == [(3.0, 0.0, 0.0)]


def test_a_directory_without_a_run_is_a_clear_error(tmp_path: Path) -> None:
    with pytest.raises(InputFileError, match="missing file of a simulation run"):
        RunRecord.load(tmp_path)
