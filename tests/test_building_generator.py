"""The test-building generator: a real IFC4 building and a complete project that every step loads."""

from __future__ import annotations

import math
import subprocess
import sys
from collections import Counter
from pathlib import Path

import ifcopenshell
import ifcopenshell.util.element
import ifcopenshell.util.placement
import pytest

from kbplanner.cli import main
from kbplanner.planning.element_order import RULE_SEQUENCE
from kbplanner.planning.planner import plan_task
from kbplanner.project import Project
from kbplanner.scale.building_generator import GeneratedBuilding, generate_building
from kbplanner.scale.building_plan import MAX_PANEL_LENGTH, SCENARIO, GeneratorError


def _files(directory: Path) -> dict[str, bytes]:
    return {str(p.relative_to(directory)): p.read_bytes() for p in sorted(directory.rglob("*"))
            if p.is_file() and ".kbplanner-cache" not in p.parts and p.name != ".kbplanner-run"}


@pytest.fixture(scope="module")
def generated(tmp_path_factory: pytest.TempPathFactory) -> GeneratedBuilding:
    return generate_building(tmp_path_factory.mktemp("gen") / "b2x2", storeys=2, units_per_storey=2, seed=3)


@pytest.fixture(scope="module")
def b2x2(generated: GeneratedBuilding) -> Path:
    return generated.directory


def test_seed_zero_gives_fourteen_frames_per_unit(tmp_path: Path) -> None:
    b = generate_building(tmp_path / "b", storeys=2, units_per_storey=3)
    assert b.frames_per_storey == (42, 42) and b.frames == 84


def test_the_same_arguments_give_byte_identical_files_across_processes(b2x2: Path, tmp_path: Path) -> None:
    again = tmp_path / "again"
    proc = subprocess.run([sys.executable, "-m", "kbplanner", "generate-building", "--storeys", "2",
                           "--units-per-storey", "2", "--seed", "3", "--out", str(again)],
                          capture_output=True, text=True, timeout=120, check=False)
    assert proc.returncode == 0, proc.stderr
    first, second = _files(b2x2), _files(again)
    assert sorted(first) == sorted(second)
    assert [k for k in first if first[k] != second[k]] == []


def test_another_seed_moves_the_partitions_but_keeps_the_counts(b2x2: Path, tmp_path: Path) -> None:
    other = generate_building(tmp_path / "s4", storeys=2, units_per_storey=2, seed=4)
    ifc = Path("model") / "building.ifc"
    assert (tmp_path / "s4" / ifc).read_bytes() != (b2x2 / ifc).read_bytes()
    assert other.counts["IfcWall"] == 40 and other.counts["IfcDoor"] == 15


def test_doors_fill_openings_that_void_their_host_walls_and_spaces_slabs_stairs_exist(b2x2: Path) -> None:
    f = ifcopenshell.open(str(b2x2 / "model" / "building.ifc"))
    assert f.schema == "IFC4"
    counts = Counter(p.is_a() for p in f.by_type("IfcProduct"))
    # per storey: 4 building + 2 x 2 unit facades, 1 + 1 party, 2 corridor, 4 partitions, 4 lift shaft walls
    assert counts["IfcWall"] == 2 * (4 + 4 + 2 + 2 + 4 + 4)
    assert counts["IfcStair"] == 2 and counts["IfcSlab"] == 2 * 4 + 1 and counts["IfcSpace"] == 2 * (2 + 6)
    for door in f.by_type("IfcDoor"):
        assert door.OverallWidth in (0.9, 1.2)
        opening = door.FillsVoids[0].RelatingOpeningElement
        host = opening.VoidsElements[0].RelatingBuildingElement
        assert host.is_a("IfcWall")
        assert ifcopenshell.util.element.get_container(door) == ifcopenshell.util.element.get_container(host)
    gids = [e.GlobalId for e in f.by_type("IfcRoot")]
    assert len(gids) == len(set(gids)) and not any("$" in g for g in gids)
    assert [u.Name for u in f.by_type("IfcSIUnit") if u.UnitType == "LENGTHUNIT"] == ["METRE"]


def test_frames_are_short_light_members_on_partition_axes_clear_of_the_door_openings(
        generated: GeneratedBuilding) -> None:
    f = ifcopenshell.open(str(generated.ifc))
    members = f.by_type("IfcMember")
    assert len(members) == generated.frames == sum(generated.frames_per_storey) > 2 * 2 * 12
    for m in members:
        psets = ifcopenshell.util.element.get_psets(m)
        mass = psets["BaseQuantities"]["NetWeight"]
        length = psets["BaseQuantities"]["Length"]
        assert 9.0 <= mass <= 14.0 and 0.3 <= length <= MAX_PANEL_LENGTH <= 1.2
        assert m.ObjectType == "Interior stud frame panel" and m.Representation is not None
        host = f.by_guid(psets["Kbplanner_StudFramePanel"]["HostWallGlobalId"])
        assert host.Name.startswith("Partition")
        assert ifcopenshell.util.element.get_container(m) == ifcopenshell.util.element.get_container(host)
        # on the host's axis, within its length, and not across any of its door openings
        wm = ifcopenshell.util.placement.get_local_placement(host.ObjectPlacement)
        mm = ifcopenshell.util.placement.get_local_placement(m.ObjectPlacement)
        rel = (mm[:3, 3] - wm[:3, 3])
        along = float(rel @ wm[:3, 0])
        assert abs(float(rel @ wm[:3, 1])) < 1e-6
        assert along >= length / 2 - 1e-6
        for rel_void in host.HasOpenings:
            opening = rel_void.RelatedOpeningElement
            om = ifcopenshell.util.placement.get_local_placement(opening.ObjectPlacement)
            start = float((om[:3, 3] - wm[:3, 3]) @ wm[:3, 0])
            assert along + length / 2 <= start + 1e-6 or along - length / 2 >= start + 0.9 - 1e-6
        assert math.isclose(abs(float(mm[:3, 0] @ wm[:3, 0])), 1.0)


def test_every_building_element_is_built_by_exactly_one_task(generated: GeneratedBuilding) -> None:
    p = Project.load(generated.directory)
    built = Counter(str(r[1]) for r in p.query("task_elements").rows)
    elements = {str(r[0]) for r in p.query("schedule_element_index").rows}
    assert set(built) == elements and set(built.values()) == {1}
    robotized = [r for r in p.query("tasks_and_elements").rows if r[5]]
    n1, n2 = generated.frames_per_storey
    assert [(r[1], r[6], r[7]) for r in robotized] == [("T-FRAME-L01", "I-W-F-#1", n1),
                                                          ("T-FRAME-L02", "I-W-F-#1", n2)]
    assert len(elements) == generated.elements


def test_the_bare_model_has_the_case_study_requirements_and_the_scenario_conforms(
        generated: GeneratedBuilding) -> None:
    bare = Project.load(generated.directory).requirements()
    n1, n2 = generated.frames_per_storey
    assert sorted((r.task_id, r.skill_id, len(r.elements)) for r in bare.requirements) == [
        ("T-FRAME-L01", "MM-G-1", n1), ("T-FRAME-L01", "NV-1", n1),
        ("T-FRAME-L02", "MM-G-1", n2), ("T-FRAME-L02", "NV-1", n2)]
    project = Project.load(generated.directory, scenario=SCENARIO)
    assert project.requirements().requirements == []
    result = project.validate()
    assert result.conforms, result.text()


def test_the_world_stacks_each_units_frames_at_its_storage_and_the_plan_is_feasible(
        generated: GeneratedBuilding) -> None:
    project = Project.load(generated.directory, scenario=SCENARIO)
    world = project.world()
    n1 = generated.frames_per_storey[0]
    assert world.unplaced() == () and len(world.task_elements) == n1
    assert {e.storage for e in world.task_elements} == {
        o.iri for o in world.storages if "L01" in o.iri}
    for storage in world.storages:
        stack = [e for e in world.task_elements if e.storage == storage.iri]
        if not stack:  # the storages of Level 2 hold the frames of the other task
            continue
        assert [e.stack_index for e in stack] == list(range(len(stack)))
        top = max(e.bounds.zmax for e in stack if e.bounds is not None)
        assert storage.pose is not None and top < storage.pose.z + 0.9  # at most 8 frames of 89 mm
    plan = plan_task(project)
    assert plan.feasible and len(plan.steps) == 4 * n1 and plan.robot_id == "husky-ur16e"
    assert plan.order_rule == RULE_SEQUENCE


def test_generate_building_cli_rejects_bad_sizes_and_foreign_directories(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["generate-building", "--storeys", "0", "--units-per-storey", "1",
                 "--out", str(tmp_path / "x")]) == 2
    assert "--storeys must be an integer from 1 to" in capsys.readouterr().err
    foreign = tmp_path / "foreign"
    foreign.mkdir()
    (foreign / "notes.txt").write_text("mine")
    argv = ["generate-building", "--storeys", "1", "--units-per-storey", "1", "--out"]
    assert main([*argv, str(foreign)]) == 2
    assert "--force" in capsys.readouterr().err and (foreign / "notes.txt").is_file()
    with pytest.raises(GeneratorError):
        generate_building(tmp_path / "y", storeys=1, units_per_storey=1, seed=-1)
    out = tmp_path / "ok"
    assert main(["generate-building", "--storeys", "1", "--units-per-storey", "1", "--out", str(out)]) == 0
    assert "14 stud-frame panels" in capsys.readouterr().out
    assert main(["generate-building", "--storeys", "1", "--units-per-storey", "2", "--out", str(out)]) == 0
    assert "28 stud-frame panels" in capsys.readouterr().out  # a generated directory is replaced


@pytest.mark.slow
def test_ten_storeys_of_ten_units_hold_more_than_a_thousand_frames(tmp_path: Path) -> None:
    # Its time is measured in benchmarks/ (bench_sweep.py, docs/scale.md), never asserted here.
    b = generate_building(tmp_path / "b10x10", storeys=10, units_per_storey=10)
    assert b.frames >= 1000 and b.elements > 2000
