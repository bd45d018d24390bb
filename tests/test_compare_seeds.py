"""``kbplanner compare --seeds``: scenarios over seeds, one definition of the safety figures, exit codes."""

from __future__ import annotations

import argparse
import csv
import json
import subprocess
import sys
from pathlib import Path

import pytest

from kbplanner.analysis.report import scenario_figures
from kbplanner.analysis.run_record import RunRecord
from kbplanner.analysis.seed_report import compare_seeds
from kbplanner.cli.arguments import seed_list
from sim_project_factory import make_sim_project

REPO = Path(__file__).resolve().parents[1]


def kbplanner(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "kbplanner", *args], capture_output=True, text=True, timeout=600
    )


@pytest.fixture(scope="module")
def project(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("seeds")
    make_sim_project(d, high_panel=False)
    return d


def test_seed_lists_ranges_and_lists() -> None:
    assert seed_list("1-20") == list(range(1, 21))
    assert seed_list("1,3,5") == [1, 3, 5]
    assert seed_list(" 4-5, 9 ") == [4, 5, 9]
    for bad in ("", "5-1", "1,1", "1-3,2", "x", "1,,2", "-3", "1-", "1.5", str(2**32)):
        with pytest.raises(argparse.ArgumentTypeError):
            seed_list(bad)


def test_bad_seed_lists_exit_2_before_any_work(project: Path, tmp_path: Path) -> None:
    for bad in ("5-1", "a-b", "1,1"):
        p = kbplanner("compare", str(project), "--scenarios", "stored", "--seeds", bad, "--out",
                      str(tmp_path / "x"))
        assert p.returncode == 2 and "--seeds" in p.stderr and "Traceback" not in p.stderr, p.stderr
    both = kbplanner("compare", str(project), "--scenarios", "stored", "--seed", "1", "--seeds", "1-2",
                     "--out", str(tmp_path / "x"))
    assert both.returncode == 2 and "not allowed with" in both.stderr
    for extra in (["--seeds", "1", "--threshold", "2"], ["--monitoring", "off"], ["--jobs", "2"]):
        p = kbplanner("compare", str(project), "--scenarios", "stored", *extra, "--out", str(tmp_path / "x"))
        assert p.returncode == 2 and "kbplanner compare:" in p.stderr, p.stderr
    assert not (tmp_path / "x").exists()


def test_compare_over_seeds_writes_runs_statistics_plot_and_summary(project: Path, tmp_path: Path) -> None:
    out = tmp_path / "cmp"
    p = kbplanner("compare", str(project), "--scenarios", "stored", "--seeds", "1-2", "--out", str(out))
    assert p.returncode == 0, p.stderr[-3000:]
    assert p.stderr.count("stored, seed ") == 4  # a line when each run starts and one when it ends
    assert "stored: 2 runs; duration median" in p.stdout
    rows = list(csv.DictReader((out / "seeds.csv").open()))
    assert [(r["scenario"], r["seed"], r["monitoring"]) for r in rows] == [("stored", "1", "ssm"),
                                                                           ("stored", "2", "ssm")]
    summary = json.loads((out / "seed_summary.json").read_text())
    fig = summary["scenarios"]["stored"]["figures"]
    seps = [float(r["min_separation_m"]) for r in rows]
    assert fig["min_separation_m"]["worst"] == pytest.approx(min(seps))
    assert fig["min_separation_m"]["median"] == pytest.approx(sum(seps) / 2, abs=1e-3)
    assert fig["collisions"] == {"median": 0, "worst": 0} and summary["collisions"] == []
    assert (out / "figures" / "seeds.png").read_bytes()[:4] == b"\x89PNG"
    assert "Over seeds" in (out / "summary.md").read_text() and (out / "summary.html").is_file()
    # docs are regenerated from such an output (benchmarks/safety_seeds_doc.py), not retyped
    doc = tmp_path / "docs" / "safety.md"
    doc.parent.mkdir()
    doc.write_text("intro\n<!-- seeds:begin -->\nold\n<!-- seeds:end -->\nrest\n")
    gen = subprocess.run([sys.executable, str(REPO / "benchmarks" / "safety_seeds_doc.py"), str(out),
                          "--doc", str(doc)], capture_output=True, text=True)
    assert gen.returncode == 0, gen.stdout + gen.stderr
    text = doc.read_text()
    assert "old" not in text and text.startswith("intro") and text.endswith("rest\n")
    assert f"| minimum separation | {fig['min_separation_m']['median']:g} m / " in text
    assert (tmp_path / "docs" / "figures" / "safety_seeds.png").is_file()
    for seed in (1, 2):
        run = out / "stored" / f"seed-{seed}"
        rec = RunRecord.load(run)
        assert rec.manifest["seed"] == seed
        # one definition (issue 11): the comparison's figures are metrics.json's ...
        f, s = scenario_figures(rec, rec.proximity()), rec.metrics["safety"]
        assert f.min_separation_m == pytest.approx(s["min_separation_m"], abs=1e-3)
        assert f.below_threshold_s == pytest.approx(s["time_below_1m_s"], abs=0.01)
        assert f.below_separation_s == pytest.approx(s["time_below_protective_s"], abs=0.01)
        # ... and an independent recomputation from trajectories.csv agrees with them
        check = subprocess.run([sys.executable, str(REPO / "benchmarks" / "safety_check.py"), str(run)],
                               capture_output=True, text=True)
        assert check.returncode == 0, check.stdout


def test_a_collision_in_any_run_is_listed_and_exits_1(project: Path, tmp_path: Path) -> None:
    # monitoring off and a worker walking her route through the robot's way without yielding
    p = kbplanner("compare", str(project), "--scenarios", "stored", "--seeds", "1", "--monitoring", "off",
                  "--scripted-workers", "--out", str(tmp_path / "off"))
    assert p.returncode == 1, p.stderr[-3000:]
    assert "COLLISIONS:" in p.stdout and "stored, seed 1: t = " in p.stdout and "carpenter" in p.stdout
    hits = json.loads((tmp_path / "off" / "seed_summary.json").read_text())["collisions"]
    assert hits and all(h["seed"] == 1 and h["worker"] == "carpenter" and h["t_s"] > 0 for h in hits)
    assert "COLLISIONS" in (tmp_path / "off" / "summary.md").read_text()


def test_over_seeds_is_deterministic_and_reports_the_cost_of_monitoring(
    project: Path, tmp_path: Path
) -> None:
    texts = []
    for k in range(2):
        out = tmp_path / f"run{k}"
        # serial, then two runs at a time in their own processes: the same outputs
        study, data = compare_seeds(project, ["stored"], [2], out_dir=out, cost_seeds=[2], max_elements=1,
                                    jobs_n=1 + k)
        texts.append([(out / n).read_text() for n in ("seeds.csv", "seed_summary.json", "summary.md")])
        assert texts[-1][0] and (out / "stored" / "seed-2-monitoring-off" / "metrics.json").is_file()
    assert texts[0] == texts[1]
    # the same summary from the run directories on disk (a study stopped early, runs made one by one)
    again = subprocess.run([sys.executable, str(REPO / "benchmarks" / "seed_summary_of_runs.py"),
                            str(tmp_path / "run0"), "--out", str(tmp_path / "again")],
                           capture_output=True, text=True)
    assert again.returncode == 0, again.stdout + again.stderr
    assert (tmp_path / "again" / "seed_summary.json").read_text() == texts[0][1]
    cost = data["scenarios"]["stored"]["monitoring_cost_s"]
    (on,), (off,) = study.of("stored"), study.of("stored", cost=True)
    assert off.monitoring == "off" and cost["seeds_compared"] == [2]
    expected = 60.0 * (float(on.figures["duration_min"] or 0) - float(off.figures["duration_min"] or 0))
    assert cost["median"] == pytest.approx(expected, abs=0.1)
