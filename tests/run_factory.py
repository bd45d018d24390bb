"""A hand-made simulation run directory with known answers (tests of analysis and report)."""

from __future__ import annotations

import json
from pathlib import Path


def write_run(d: Path) -> None:
    """A tiny hand-made run directory: 5 samples, one frame F01, one worker (see test_run_record)."""
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
