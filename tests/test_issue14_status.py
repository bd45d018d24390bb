"""``benchmarks/issue14_status.py``: issue 14's aims against the benchmarks' JSON and a seed study's runs
(the table in docs/scale.md), run as a user runs it, on files written here in the benchmarks' formats."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SCRIPT = REPO / "benchmarks" / "issue14_status.py"


def _metrics(run: Path, monitoring: str, frame: tuple[float, float], leg: tuple[float, float]) -> None:
    run.mkdir(parents=True)
    quality = {"time_over_lower_bound": {"count": 11, "median": frame[0], "max": frame[1]},
               "driven_over_shortest": {"count": 22, "median": leg[0], "max": leg[1]}}
    (run / "metrics.json").write_text(json.dumps({"safety": {"monitoring": monitoring},
                                                  "path_quality": quality}))


def test_aims_are_judged_from_the_files_and_monitoring_off_runs_are_left_out(tmp_path: Path) -> None:
    study = tmp_path / "study"
    _metrics(study / "storage-inside" / "seed-1", "ssm", (1.10, 1.25), (1.01, 1.20))
    _metrics(study / "storage-inside" / "seed-2", "ssm", (1.20, 1.35), (1.02, 1.10))
    _metrics(study / "storage-inside" / "seed-3", "ssm", (1.12, 1.30), (1.00, 1.05))
    _metrics(study / "storage-inside" / "seed-1-monitoring-off", "off", (2.0, 3.0), (2.0, 3.0))
    scale = tmp_path / "scale10.json"
    scale.write_text(json.dumps({"after": {"run_s": 181.5}, "load_average_start": [1.2, 1, 1]}))
    first = tmp_path / "first.json"
    first.write_text(json.dumps({"machine": {"cpus": 2, "python_loop_1e6_s": 0.0875},
                                 "scenarios": [{"scenario": "storage-inside", "rounds": 3, "after": {
                                     "x_real_time_simulation_cpu": 301.0, "x_real_time_command": 99.9}}]}))
    out = tmp_path / "status.json"
    proc = subprocess.run([sys.executable, str(SCRIPT), "--first", str(first), "--scale10", str(scale),
                           "--study", str(study), "--out", str(out)],
                          capture_output=True, text=True, check=True)
    rows = {r["item"]: r for r in json.loads(out.read_text())["rows"]}
    assert rows["first run: `simulate` storage-inside: step"]["met"] is True
    assert rows["first run: `simulate` storage-inside: command"]["met"] is False
    assert rows["10 x 8 building, `kbplanner run`"]["met"] is False
    frame_median = rows["storage-inside: frame time / lower bound, median"]
    # the monitoring-off run (2.0) is not counted
    assert frame_median["measured"] == 1.12 and frame_median["met"] is True
    frame_max = rows["storage-inside: frame time / lower bound, max"]
    assert frame_max["measured"] == 1.35 and frame_max["met"] is False
    assert "1 run(s) over 1.3" in frame_max["note"]  # 1.30 itself is within the aim
    assert rows["storage-inside: driven / shortest path, max"]["met"] is True
    assert rows["start-up: --version"]["measured"] is None and rows["start-up: --version"]["met"] is None
    assert "| 10 x 8 building, `kbplanner run` |" in proc.stdout and "**no**" in proc.stdout
    # the machine's speed where a file recorded it (scale10.json here has none)
    assert json.loads(out.read_text())["python_loop_1e6_s"] == {"first.json": 0.0875}
    assert "`first.json` 0.0875 s" in proc.stdout and "scale10.json`" not in proc.stdout.split("Machine")[1]


def test_a_file_that_is_no_benchmark_result_is_named_with_the_fix(tmp_path: Path) -> None:
    bad = tmp_path / "scale10.json"
    bad.write_text("[1, 2]")
    proc = subprocess.run([sys.executable, str(SCRIPT), "--scale10", str(bad),
                           "--out", str(tmp_path / "o.json")], capture_output=True, text=True)
    assert proc.returncode == 1
    assert str(bad) in proc.stderr and "benchmark script" in proc.stderr and "Traceback" not in proc.stderr
    assert not (tmp_path / "o.json").exists()
