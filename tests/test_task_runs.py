"""Whole-building runs: every robotized task of a generated two-storey building, serial and on 2 processes."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from kbplanner.cli import main
from kbplanner.core.errors import KbplannerError
from kbplanner.project import Project
from kbplanner.scale.building_generator import generate_building
from kbplanner.scale.task_runs import robotized_tasks, simulate_tasks

SCENARIO = "storage-in-units"


@pytest.fixture(scope="module")
def building(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("tasks") / "b2x1"
    generate_building(out, storeys=2, units_per_storey=1)
    return out


@pytest.mark.slow  # about 40 s: `make test-slow` (.ci/run runs it after `make test`)
def test_every_task_is_simulated_alike_serially_and_on_two_processes(building: Path, tmp_path: Path) -> None:
    serial = simulate_tasks(building, SCENARIO, out_dir=tmp_path / "serial", max_elements=1)
    parallel = simulate_tasks(building, SCENARIO, out_dir=tmp_path / "parallel", max_elements=1, workers=2)
    assert [t.task_id for t in serial.tasks] == ["T-FRAME-L01", "T-FRAME-L02"]
    assert serial.tasks == parallel.tasks
    assert serial.installed == serial.elements == 2
    for name in ("tasks.csv", "tasks.json"):
        assert (tmp_path / "serial" / name).read_bytes() == (tmp_path / "parallel" / name).read_bytes()
    for task in ("T-FRAME-L01", "T-FRAME-L02"):
        for name in ("trajectories.csv", "metrics.json", "plan.json"):
            a = (tmp_path / "serial" / task / name).read_bytes()
            assert a == (tmp_path / "parallel" / task / name).read_bytes(), (task, name)
    timings = json.loads((tmp_path / "parallel" / "tasks_timings.json").read_text())
    assert timings["workers"] == 2 and set(timings["tasks"]) == {"T-FRAME-L01", "T-FRAME-L02"}


def test_an_upper_storey_task_starts_at_its_arrival_and_works_on_its_floor(building: Path,
                                                                           tmp_path: Path) -> None:
    result = simulate_tasks(building, SCENARIO, out_dir=tmp_path / "runs", tasks=["T-FRAME-L02"],
                            max_elements=1)
    (task,) = result.tasks
    assert task.installed == 1 and task.world_date.startswith(str(robotized_tasks(
        Project.load(building, scenario=SCENARIO))[1][2].date()))
    manifest = json.loads((tmp_path / "runs" / "T-FRAME-L02" / "manifest.json").read_text())
    assert manifest["robot_floor_z"] == pytest.approx(3.0) and manifest["ground_z"] == pytest.approx(0.0)
    rows = (tmp_path / "runs" / "T-FRAME-L02" / "trajectories.csv").read_text().splitlines()
    first = dict(zip(rows[0].split(","), rows[1].split(","), strict=True))
    project = Project.load(building, scenario=SCENARIO)
    world = project.world(at=robotized_tasks(project)[1][2], task_id="T-FRAME-L02")
    assert world.robot_start is not None and world.robot_start.z == pytest.approx(3.0)
    assert (float(first["x"]), float(first["y"])) == pytest.approx((world.robot_start.x, world.robot_start.y))
    # workers walk on the ground, the robot works one storey up: at least the storey height apart
    assert task.min_separation_m >= 3.0 - 0.25 - 1e-6


def test_an_unknown_task_is_a_clear_error(building: Path, tmp_path: Path) -> None:
    with pytest.raises(KbplannerError) as err:
        simulate_tasks(building, SCENARIO, out_dir=tmp_path / "x", tasks=["T-NOPE"])
    assert "T-NOPE" in str(err.value) and "T-FRAME-L01" in str(err.value)


@pytest.mark.slow  # about 25 s
def test_kbplanner_run_tasks_all_writes_the_task_table(building: Path, tmp_path: Path,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "run"
    code = main(["run", str(building), "--out", str(out), "--tasks", "all", "--workers", "2",
                 "--max-elements", "1", "--scenario", SCENARIO])
    assert code == 0, capsys.readouterr()
    sdir = out / "scenarios" / SCENARIO
    table = (sdir / "tasks" / "tasks.csv").read_text().splitlines()
    assert table[0].startswith("task,")
    assert [r.split(",")[0] for r in table[1:]] == ["T-FRAME-L01", "T-FRAME-L02", "all"]
    assert (sdir / "simulation" / "trajectories.csv").is_file()  # the [simulation] task, for the report
    assert (sdir / "tasks" / "T-FRAME-L02" / "trajectories.csv").is_file()
    html = (out / "report.html").read_text(encoding="utf-8")
    assert "Every robotized task (whole building)" in html and "T-FRAME-L02" in html
    assert "2/2 (2 tasks)" in capsys.readouterr().out


def test_a_task_other_than_the_simulation_task_gets_the_world_at_its_start(building: Path) -> None:
    project = Project.load(building, scenario=SCENARIO)
    (first, _l1, _s1), (second, _l2, start) = [t[:3] for t in robotized_tasks(project)]
    assert project.world_date(first) == project.world_date(None)  # the [simulation] task: its date
    assert start is not None and project.world_date(second) == start
    assert project.world(task_id=second).at == start


def test_a_robot_arrival_without_an_elevation_does_not_conform(building: Path) -> None:
    from rdflib import URIRef

    from kbplanner.core.vocab import KBP

    project = Project.load(building, scenario=SCENARIO)
    assert project.validate().conforms
    arrival = next(project.model.objects(None, KBP.robotArrival))
    assert isinstance(arrival, URIRef)
    project.model.remove((arrival, KBP.z, None))
    result = project.validate()
    assert not result.conforms
    assert any("kbp:z" in r.message for r in result.violations)


def _files(root: Path) -> dict[str, bytes]:
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


# wall-clock files (not deterministic by design: docs/scale.md); the run folders' markers name the command
# (with its --workers)
WALL_CLOCK = {"run_timings.json", "tasks_timings.json", "timing.json", ".kbplanner-run"}


@pytest.mark.slow  # about 60 s: two pipeline runs of three storeys
def test_a_whole_building_run_writes_the_same_files_serially_and_on_two_processes(
        tmp_path_factory: pytest.TempPathFactory, tmp_path: Path) -> None:
    project = tmp_path_factory.mktemp("tasks3") / "b3x1"
    generate_building(project, storeys=3, units_per_storey=1)
    runs = {}
    for workers in (1, 2):
        out = tmp_path / f"w{workers}"
        code = main(["run", str(project), "--out", str(out), "--tasks", "all", "--workers", str(workers),
                     "--max-elements", "1", "--scenario", SCENARIO])
        assert code == 0
        runs[workers] = {k: v for k, v in _files(out).items() if k.rsplit("/", 1)[-1] not in WALL_CLOCK}
    assert sorted(runs[1]) == sorted(runs[2])
    assert "scenarios/storage-in-units/tasks/T-FRAME-L03/trajectories.csv" in runs[1]
    assert [k for k in runs[1] if runs[1][k] != runs[2][k]] == []
    tasks = tmp_path / "w2" / "scenarios" / SCENARIO / "tasks"
    marker = json.loads((tasks / "T-FRAME-L02" / ".kbplanner-run").read_text())
    assert marker["command"].startswith("kbplanner run ")  # the command, whichever process ran the task


def test_tasks_start_with_the_main_task_then_the_largest() -> None:
    from kbplanner.scale.task_runs import _Job, _longest_first

    def job(task_id: str, main: bool = False) -> _Job:
        return _Job(Path("p"), None, task_id, task_id, None, Path("o"), task_id, False, main, None)

    jobs = [job("A"), job("B"), job("C", main=True), job("D")]
    assert _longest_first(jobs, [5, 9, 1, 9]) == [2, 1, 3, 0]
