"""Scenario sweeps: variants, the storage overlay, free-space checks, serial = parallel, Pareto front, CLI."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import pytest

from kbplanner.cli import main
from kbplanner.core.errors import KbplannerError
from kbplanner.project import Project
from kbplanner.scale.sweep import SweepSpec, build_variants, prepare_base, run_sweep
from kbplanner.scale.sweep_axes import SweepError, parse_vary
from kbplanner.scale.sweep_backends import execute
from kbplanner.scale.sweep_pareto import pareto_front
from kbplanner.scale.sweep_simulate import FAILED, OK, REJECTED, VariantResult, shifted_workers
from kbplanner.scale.sweep_storage import (
    apply_overlay,
    find_storage,
    grid_candidates,
    site_check,
    storage_overlay,
)
from sim_project_factory import EXTENT, PICKUP, STORAGE, make_sim_project

IN_WALL = "0.15,3.0,1.5708"  # the storage standing lengthwise in the west wall (x 0..0.3)


@pytest.fixture(scope="module")
def project(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("sweep")
    make_sim_project(d, high_panel=False)
    return d


Pose2 = tuple[float, float, float]


def _rel(storage: Pose2, pickup: Pose2) -> Pose2:
    sx, sy, syaw = storage
    px, py, pyaw = pickup
    c, s = math.cos(-syaw), math.sin(-syaw)
    return (c * (px - sx) - s * (py - sy), s * (px - sx) + c * (py - sy),
            math.atan2(math.sin(pyaw - syaw), math.cos(pyaw - syaw)))


def test_variants_are_the_product_of_the_axes_with_deterministic_ids_and_seeds(project: Path) -> None:
    spec = SweepSpec(project, scenario="stored",
                     axes=parse_vary(["storage=stored;2.5,-4.0", "seed=5,6", "start=07:00,09:30"]))
    prepared = prepare_base(spec)
    assert prepared is not None
    first, rej1 = build_variants(spec, base=prepared[0], grid=prepared[1])
    second, rej2 = build_variants(spec, base=prepared[0], grid=prepared[1])
    assert first == second and rej1 == rej2 == {}
    ids = [v.id for v in first]
    assert ids[:3] == ["v001-stored-s5-t0700", "v002-stored-s5-t0930", "v003-stored-s6-t0700"]
    assert len(first) == 8 and len({v.id for v in first}) == 8
    assert [v.seed for v in first] == [5, 5, 6, 6, 5, 5, 6, 6]
    assert {v.start_offset_s for v in first} == {0.0, 2.5 * 3600}
    moved = first[-1]
    assert moved.storage is not None and moved.storage.moved
    assert (moved.storage.x, moved.storage.y) == (2.5, -4.0)


def test_moving_the_storage_moves_its_pickup_location_with_the_same_relative_pose(project: Path) -> None:
    p = Project.load(project, scenario="stored")
    st = find_storage(p.model)
    assert (st.x, st.y, st.yaw) == (STORAGE[0], STORAGE[1], STORAGE[3])
    before = _rel((st.x, st.y, st.yaw), st.pickup)
    apply_overlay(p.model, storage_overlay(st, -1.0, -5.0, math.pi / 2))
    moved = find_storage(p.model)
    assert (moved.x, moved.y, moved.yaw) == (-1.0, -5.0, pytest.approx(math.pi / 2))
    after = _rel((moved.x, moved.y, moved.yaw), moved.pickup)
    assert after == pytest.approx(before, abs=1e-5)
    # pickup 1 m north of the storage facing south; turned by +90 deg: 1 m west, facing east (0 rad)
    assert moved.pickup == pytest.approx((-1.0 - 1.0, -5.0, 0.0), abs=1e-5)
    assert before == pytest.approx((PICKUP[0] - STORAGE[0], PICKUP[1] - STORAGE[1], PICKUP[3]), abs=1e-6)
    # the world built from the edited model has the storage and its pickup there; the file is untouched
    obj = next(o for o in p.world().site_objects if o.iri == st.iri)
    assert (obj.pose.x, obj.pose.y) == (-1.0, -5.0) and obj.pickup is not None
    assert (obj.pickup.x, obj.pickup.y) == pytest.approx((-2.0, -5.0))
    assert "kbp:x -1.0" not in (project / "stored.ttl").read_text()


def test_a_storage_inside_a_wall_is_rejected_and_free_ground_is_accepted(project: Path) -> None:
    spec = SweepSpec(project, scenario="stored", axes=parse_vary([f"storage={IN_WALL};-1.0,-5.0"]))
    prepared = prepare_base(spec)
    assert prepared is not None
    st, grid = prepared
    assert site_check(grid, st, STORAGE[0], STORAGE[1], 0.0) is None  # where the scenario has it
    why = site_check(grid, st, 0.15, 3.0, 1.5708)
    assert why is not None and "overlaps an obstacle" in why
    variants, rejected = build_variants(spec, base=st, grid=grid)
    assert list(rejected) == [variants[0].id] and "overlaps an obstacle" in rejected[variants[0].id]


def test_grid_candidates_are_free_inside_the_site_and_deterministic(project: Path) -> None:
    spec = SweepSpec(project, scenario="stored", axes=parse_vary(["storage=grid:2.0"]))
    prepared = prepare_base(spec)
    assert prepared is not None
    st, grid = prepared
    cands = grid_candidates(grid, st, 2.0)
    assert cands == grid_candidates(grid, st, 2.0) and 5 <= len(cands) < 60
    x0, y0, x1, y1 = EXTENT
    for c in cands:
        assert c.x is not None and c.y is not None
        assert x0 < c.x < x1 and y0 < c.y < y1 and site_check(grid, st, c.x, c.y, st.yaw) is None
        assert not (0.0 <= c.x <= 5.0 and -0.4 <= c.y <= 0.3)  # never across the south wall
    variants, rejected = build_variants(spec, base=st, grid=grid)
    assert len(variants) == len(cands) and rejected == {}


def test_a_later_start_shifts_the_workers_into_their_day(project: Path) -> None:
    p = Project.load(project, scenario="stored")
    from kbplanner.world.maps import storey_map

    grid = storey_map(p.world()).grid
    day = shifted_workers(p, grid, seed=3, horizon_s=1000.0, offset_s=0.0)
    later = shifted_workers(p, grid, seed=3, horizon_s=600.0, offset_s=250.0)
    assert len(day) == len(later) == 1
    for t in (0.0, 13.7, 100.0, 400.0):
        assert later[0].position(t) == pytest.approx(day[0].position(t + 250.0))
    assert later[0].horizon_s >= 600.0


def _row(vid: str, safety: float | None, total: float | None, status: str = OK,
         installed: int = 2) -> VariantResult:
    return VariantResult(variant=vid, scenario="s", storage=vid, storage_x=0.0, storage_y=0.0,
                         storage_yaw=0.0,
                         seed=1, start="07:00", status=status, installed=installed, elements=2,
                         total_min=total, below_threshold_s=safety, below_separation_s=safety)


def test_pareto_front_of_a_hand_made_table_is_the_non_dominated_complete_variants() -> None:
    rows = [
        _row("a", 10.0, 30.0),   # front: fastest
        _row("b", 5.0, 32.0),    # front
        _row("c", 6.0, 33.0),    # dominated by b
        _row("d", 0.0, 40.0),    # front: safest
        _row("e", 10.0, 31.0),   # dominated by a
        _row("f", 0.0, 41.0),    # dominated by d
        _row("g", 0.0, 10.0, installed=1),  # incomplete: never on the front
        _row("h", None, None, status=REJECTED, installed=0),
        _row("i", 5.0, 32.0),    # equal to b: both stay
    ]
    assert [r.variant for r in pareto_front(rows)] == ["a", "b", "i", "d"]
    assert [r.variant for r in pareto_front(rows, "iso")] == ["a", "b", "i", "d"]
    assert pareto_front([_row("h", None, None, status=FAILED, installed=0)]) == []
    with pytest.raises(SweepError, match="threshold or iso"):
        pareto_front(rows, "fastest")


@pytest.mark.parametrize("vary, says", [
    ("storage", "expected AXIS=VALUES"),
    ("colour=red", "AXIS one of storage, seed, start"),
    ("seed=1,two", "seed 'two' is not an integer"),
    ("start=7am", "is not HH:MM"),
    ("storage=1.0", "scenario name, X,Y"),
    ("storage=grid:-1", "positive number of metres"),
    ("storage=nowhere", "scenarios: stored, walled"),
])
def test_bad_vary_syntax_exits_2_with_a_clear_message(
    project: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], vary: str, says: str
) -> None:
    assert main(["sweep", str(project), "--vary", vary, "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert says in err and "fix:" in err and "Traceback" not in err


def test_sweep_cli_reports_a_candidate_inside_a_wall_as_a_rejected_row(project: Path, tmp_path: Path) -> None:
    out = tmp_path / "sw"
    proc = subprocess.run([sys.executable, "-m", "kbplanner", "sweep", str(project), "--scenario", "stored",
                           "--vary", f"storage={IN_WALL}", "--out", str(out)],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 1, proc.stderr[-2000:]  # nothing simulated: no Pareto front
    assert "rejected" in proc.stdout and "overlaps an obstacle" in proc.stdout
    lines = (out / "sweep.csv").read_text().splitlines()
    assert lines[0].startswith("variant,scenario,storage,storage_x") and len(lines) == 2
    assert ',rejected,"storage footprint overlaps an obstacle at' in lines[1]
    assert (out / "pareto.png").read_bytes()[:4] == b"\x89PNG"
    assert (out / "pareto.csv").read_text().count("\n") == 1


def test_missing_cluster_extras_name_the_pip_extra(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "ray", None)
    with pytest.raises(KbplannerError, match=r"kbplanner\[ray\]"):
        execute([], cluster="ray://127.0.0.1:10001")
    monkeypatch.setitem(sys.modules, "dask.distributed", None)
    with pytest.raises(KbplannerError, match=r"kbplanner\[cluster\]"):
        execute([], cluster="dask://127.0.0.1:8786")
    with pytest.raises(KbplannerError, match="dask://HOST:PORT"):
        execute([], cluster="spark://x:1")


@pytest.mark.slow  # about 30 s: `make test-slow` (.ci/run runs it after `make test`)
def test_serial_and_two_process_sweeps_write_byte_identical_tables(project: Path, tmp_path: Path) -> None:
    spec = SweepSpec(project, scenario="stored", max_elements=1,
                     axes=parse_vary(["storage=stored;2.5,-4.5", f"storage={IN_WALL}"]))
    serial = run_sweep(spec, out_dir=tmp_path / "serial", workers=1)
    parallel = run_sweep(spec, out_dir=tmp_path / "parallel", workers=2, keep_runs=True)
    assert [r.status for r in serial.rows] == [OK, OK, REJECTED] and parallel.rows == serial.rows
    assert all(r.installed == r.elements == 1 for r in serial.rows[:2])
    assert serial.rows[1].storage_x == 2.5 and serial.rows[1].storage_y == -4.5
    for name in ("sweep.csv", "sweep.json", "pareto.csv"):
        assert (tmp_path / "serial" / name).read_bytes() == (tmp_path / "parallel" / name).read_bytes(), name
    assert serial.front and all(r.complete for r in serial.front)
    runs = sorted(p.name for p in (tmp_path / "parallel" / "runs").iterdir())
    assert runs == [r.variant for r in serial.rows[:2]]
    assert (tmp_path / "parallel" / "runs" / runs[1] / "trajectories.csv").is_file()
    assert not (tmp_path / "serial" / "runs").exists()
