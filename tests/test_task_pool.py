"""Whole-building runs, the processes: start order from the last run's costs, the costs file, the
stage's wall-clock figures; and a run of two scenarios sharing two processes writes what one process
writes."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from kbplanner.cli import main
from kbplanner.scale.building_generator import generate_building
from kbplanner.scale.task_jobs import TaskFigures, _Job
from kbplanner.scale.task_pool import COSTS_FILE, cost_key, read_costs, start_order, write_costs
from kbplanner.scale.task_runs import SimulationStage, TaskRunsResult


def _job(scenario: str, task_id: str, main: bool = False, max_elements: int | None = None) -> _Job:
    return _Job(Path("p"), scenario, task_id, task_id, None, Path("o"), task_id, False, main, max_elements)


def test_jobs_start_by_last_run_s_cpu_seconds_when_every_job_has_one() -> None:
    jobs = [_job("in", "FRAME", main=True), _job("in", "BOARD"), _job("out", "FRAME", main=True),
            _job("out", "BOARD")]
    sizes = [11, 5, 11, 5]
    costs = {cost_key(j): c for j, c in zip(jobs, (13.4, 4.4, 21.3, 23.2), strict=True)}
    assert start_order(jobs, sizes, costs) == [3, 2, 0, 1]  # the long board task outside first
    del costs[cost_key(jobs[3])]  # a job never run: the main tasks first, then most elements
    assert start_order(jobs, sizes, costs) == [0, 2, 1, 3]
    assert cost_key(_job("in", "FRAME", max_elements=2)) != cost_key(_job("in", "FRAME"))


def test_costs_are_kept_per_project_in_the_project_cache_and_never_with_the_cache_off(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("KBPLANNER_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.delenv("KBPLANNER_NO_CACHE", raising=False)
    a, b = tmp_path / "a", tmp_path / "b"
    assert read_costs(a) == {}
    write_costs(a, {"s|T1|all": 3.14159})
    write_costs(b, {"s|T1|all": 9.0})
    write_costs(a, {"s|T2|all": 1.0})
    assert read_costs(a) == {"s|T1|all": 3.14, "s|T2|all": 1.0}
    assert read_costs(b) == {"s|T1|all": 9.0}
    (tmp_path / "cache" / COSTS_FILE).write_text("not json", encoding="utf-8")
    assert read_costs(a) == {}  # only the start order depends on it: an unreadable file is no error
    write_costs(a, {"s|T1|all": 2.0})
    assert read_costs(a) == {"s|T1|all": 2.0}
    monkeypatch.setenv("KBPLANNER_NO_CACHE", "1")
    assert read_costs(a) == {}
    monkeypatch.setenv("KBPLANNER_CACHE_DIR", str(tmp_path / "other"))
    write_costs(a, {"s|T1|all": 2.0})
    assert not (tmp_path / "other").exists()


def _figures(task_id: str, sim_s: float) -> TaskFigures:
    return TaskFigures(task_id, task_id, "2024-01-01T07:00:00", 1, 1, sim_s, sim_s / 60.0, 2.0, 0.0, 0,
                       task_id)


def test_the_stage_states_simulated_wall_and_cpu_seconds_and_the_real_time_factor(tmp_path: Path) -> None:
    inside = TaskRunsResult("inside", tmp_path / "in", tasks=[_figures("A", 600.0), _figures("B", 300.0)],
                            wall_s=6.0, task_wall_s={"A": 4.0, "B": 2.0}, workers=2,
                            task_cpu_s={"A": 3.5, "B": 1.5},
                            task_span_s={"A": (0.0, 4.0, 0), "B": (4.0, 6.0, 0)})
    outside = TaskRunsResult("outside", tmp_path / "out", tasks=[_figures("A", 1500.0)], wall_s=10.0,
                             task_wall_s={"A": 10.0}, workers=2, task_cpu_s={"A": 9.0},
                             task_span_s={"A": (0.0, 10.0, 1)})
    t = SimulationStage([inside, outside], 10.0, 2).timing()
    assert (t["sim_time_s"], t["wall_s"], t["cpu_s"], t["real_time_factor"]) == (2400.0, 10.0, 14.0, 240.0)
    assert t["busy"] == 0.7  # 14 s CPU of 2 x 10 s
    assert t["scenarios"]["inside"]["real_time_factor"] == 150.0
    assert t["scenarios"]["outside"]["per_task"]["A"] == {"sim_time_s": 1500.0, "wall_s": 10.0, "cpu_s": 9.0,
                                                          "start_s": 0.0, "end_s": 10.0, "process": 1}
    inside.out_dir.mkdir()
    inside.write(inside.out_dir)
    written = json.loads((inside.out_dir / "tasks_timings.json").read_text())
    assert written["tasks"] == {"A": 4.0, "B": 2.0} and written["real_time_factor"] == 150.0


def _files(root: Path) -> dict[str, bytes]:
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


WALL_CLOCK = {"run_timings.json", "tasks_timings.json", "timing.json", ".kbplanner-run"}


@pytest.mark.slow  # about 70 s: two pipeline runs of two scenarios x two storeys
def test_two_scenarios_sharing_two_processes_write_what_one_process_writes(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("KBPLANNER_CACHE_DIR", str(tmp_path / "cache"))
    project = tmp_path / "b2x1"
    generate_building(project, storeys=2, units_per_storey=1)
    with (project / "project.toml").open("a", encoding="utf-8") as fh:  # a second scenario: same storages
        fh.write('\n[scenarios.second-copy]\ndescription = "the same storages again"\n'
                 'overlays = ["scenarios/storage_in_units.ttl", "augmentation/grasp_points.ttl"]\n')
    runs = {}
    for workers in (1, 2):
        out = tmp_path / f"w{workers}"
        assert main(["run", str(project), "--out", str(out), "--tasks", "all", "--workers", str(workers),
                     "--max-elements", "1"]) == 0
        runs[workers] = {k: v for k, v in _files(out).items() if k.rsplit("/", 1)[-1] not in WALL_CLOCK}
    assert sorted(runs[1]) == sorted(runs[2])
    assert "scenarios/second-copy/tasks/T-FRAME-L02/trajectories.csv" in runs[1]
    assert [k for k in runs[1] if runs[1][k] != runs[2][k]] == []
    timings = json.loads((tmp_path / "w2" / "run_timings.json").read_text())
    sim = timings["simulation"]
    assert sim["workers"] == 2 and set(sim["scenarios"]) == {"second-copy", "storage-in-units"}
    per_scenario = sum(s["sim_time_s"] for s in sim["scenarios"].values())
    assert sim["sim_time_s"] == pytest.approx(per_scenario, abs=0.2)
    shared = [s for s in timings["stages"] if s["stage"] == "simulation (every task)"]
    assert [s["scenario"] for s in shared] == [None]  # one stage for both scenarios
    serial = json.loads((tmp_path / "w1" / "run_timings.json").read_text())
    assert [s["scenario"] for s in serial["stages"] if s["stage"] == "simulation (every task)"] == \
        ["second-copy", "storage-in-units"]
    costs = read_costs(project)
    assert set(costs) == {f"{s}|T-FRAME-L0{k}|1" for s in ("second-copy", "storage-in-units") for k in (1, 2)}


def test_without_task_costs_the_run_folder_being_replaced_gives_the_start_order(tmp_path: Path) -> None:
    from kbplanner.scale.task_pool import previous_costs

    jobs = [_job("in", "FRAME", main=True), _job("in", "BOARD"), _job("out", "FRAME", main=True),
            _job("out", "BOARD")]
    sizes = [11, 5, 11, 5]
    for scenario, walls in (("in", {"FRAME": 17.0, "BOARD": 6.5}), ("out", {"FRAME": 33.6, "BOARD": 40.0})):
        tasks = tmp_path / scenario / "tasks"
        tasks.mkdir(parents=True)
        (tasks / "tasks_timings.json").write_text(json.dumps({"tasks": walls}), encoding="utf-8")
        (tasks / "tasks.json").write_text(json.dumps({"tasks": [
            {"task_id": "FRAME", "elements": 11}, {"task_id": "BOARD", "elements": 5}]}), encoding="utf-8")
    previous = {s: tmp_path / s / "tasks" for s in ("in", "out")}
    costs = previous_costs(jobs, sizes, previous)
    assert start_order(jobs, sizes, costs) == [3, 2, 0, 1]
    assert previous_costs(jobs, [11, 5, 11, 2], previous).get(cost_key(jobs[3])) is None  # other size
    assert previous_costs(jobs, sizes, {"in": tmp_path / "nowhere"}) == {}


@pytest.mark.slow  # about 60 s: two pipeline runs of two scenarios x two storeys
def test_tasks_begun_before_validation_are_dropped_with_a_scenario_that_does_not_conform(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """With several workers the tasks start while the scenarios are validated; a scenario that does not
    conform is then not simulated, and nothing its tasks wrote ahead is left in the run folder."""
    monkeypatch.setenv("KBPLANNER_CACHE_DIR", str(tmp_path / "cache"))
    project = tmp_path / "b2x1"
    generate_building(project, storeys=2, units_per_storey=1)
    with (project / "project.toml").open("a", encoding="utf-8") as fh:  # no grasp points: does not conform
        fh.write('\n[scenarios.no-grasp-points]\ndescription = "the storages, without grasp points"\n'
                 'overlays = ["scenarios/storage_in_units.ttl"]\n')
    runs = {}
    for workers in (1, 2):
        out = tmp_path / f"w{workers}"
        assert main(["run", str(project), "--out", str(out), "--tasks", "all", "--workers", str(workers),
                     "--max-elements", "1"]) == 1
        runs[workers] = {k: v for k, v in _files(out).items() if k.rsplit("/", 1)[-1] not in WALL_CLOCK}
    assert "scenarios/storage-in-units/tasks/T-FRAME-L02/trajectories.csv" in runs[2]
    assert not [k for k in runs[2] if k.startswith(("scenarios/no-grasp-points/tasks",
                                                    "scenarios/no-grasp-points/simulation"))]
    assert sorted(runs[1]) == sorted(runs[2])
    assert [k for k in runs[1] if runs[1][k] != runs[2][k]] == []
    costs = read_costs(project)
    assert set(costs) == {f"storage-in-units|T-FRAME-L0{k}|1" for k in (1, 2)}


def test_an_unconfirmed_scenario_s_error_is_held_until_it_is_confirmed_or_dropped(tmp_path: Path) -> None:
    """A job begun before its scenario is known to be simulated fails: nothing is raised until the
    scenario is confirmed (then the error is), and a dropped scenario's error is forgotten."""
    from kbplanner.core.errors import ProjectError
    from kbplanner.scale.task_pool import Dispatch

    project = tmp_path / "b1x1"
    generate_building(project, storeys=1, units_per_storey=1)
    job = _Job(project, "no-such-scenario", "T-FRAME-L01", "T-FRAME-L01", None, tmp_path / "o", "o", False,
               True, 1)
    told: list[str] = []
    for verdict in ("confirm", "drop"):
        run = Dispatch([job], [0], 1, lambda j, _o: told.append(j.task_id), unconfirmed=["no-such-scenario"])
        run.run_here()
        assert run.held and not run.failed
        if verdict == "confirm":
            run.confirm("no-such-scenario")
            with pytest.raises(ProjectError, match="unknown scenario"):
                run.wait()
        else:
            run.drop("no-such-scenario")
            run.settle("no-such-scenario")
            assert run.wait() == {} and not run.held
    assert told == []


def test_a_released_pool_s_process_ends_while_the_caller_goes_on_and_leaving_waits_for_it(
        tmp_path: Path) -> None:
    import os

    from kbplanner.scale.task_pool import TaskPool

    with TaskPool(tmp_path, None, 2, load=False) as pool:
        assert pool.executor is not None
        child = pool.executor.submit(os.getpid).result()
        assert child != os.getpid()
        pool.release()  # returns at once: the process ends beside the caller's own work
        pool.release()  # a second call changes nothing
        with pytest.raises(RuntimeError):  # no job after the release
            pool.executor.submit(os.getpid)
    assert pool.ending is not None and not pool.ending.is_alive()
    with pytest.raises(ProcessLookupError):  # ended and reaped when the pool was left
        os.kill(child, 0)


def test_an_error_after_the_release_leaves_the_pool_at_once_and_its_process_ends(tmp_path: Path) -> None:
    import os

    from kbplanner.scale.task_pool import TaskPool

    with pytest.raises(ValueError, match="the report failed"), \
            TaskPool(tmp_path, None, 2, load=False) as pool:
        assert pool.executor is not None
        child = pool.executor.submit(os.getpid).result()
        pool.release()
        raise ValueError("the report failed")
    assert pool.ending is not None
    pool.ending.join(timeout=60.0)
    assert not pool.ending.is_alive()
    with pytest.raises(ProcessLookupError):
        os.kill(child, 0)


def test_a_gated_spawned_process_takes_no_job_before_its_earlier_work_is_done(tmp_path: Path) -> None:
    """With a gate (the pipeline's validations, given to the spawned processes first), the first jobs go
    to whichever process is free first: here the caller's, which takes both while the gate is open."""
    from concurrent.futures import Future

    from kbplanner.scale.task_pool import Dispatch, TaskPool

    project = tmp_path / "b1x1"
    generate_building(project, storeys=1, units_per_storey=1)
    names = ["no-such-a", "no-such-b"]  # each job fails at once, its error held (unconfirmed)
    jobs = [_Job(project, n, "T-FRAME-L01", "T-FRAME-L01", None, tmp_path / n, n, False, True, 1)
            for n in names]
    gate: Future[None] = Future()
    with TaskPool(project, None, 2, load=False) as pool:
        run = Dispatch(jobs, [0, 1], 2, lambda _j, _o: None, pool, unconfirmed=names)
        run.begin(here=False, gate=[gate])
        assert run.run_one() and run.run_one()  # both taken here: the spawned process waits
        assert sorted(run.held) == [0, 1] and not run.run_one()
        gate.set_result(None)
        for n in names:
            run.drop(n)
        assert run.wait() == {}
