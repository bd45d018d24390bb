"""``kbplanner init`` (issue 10 item 2): an IFC file to a complete project that validates.

Fast tests use the ifcopenshell-written test building (tests/ifc_factory.py) and the trait fixtures
(tests/ifc_traits.py: unnamed property sets in IFC2X3, gram units, a split-level slab, a door without
a host wall, a storey without spaces); the Duplex and the public models of /work/shared are used when
present (skipped otherwise).
"""

from __future__ import annotations

import hashlib
import re
from collections.abc import Callable
from pathlib import Path

import ifcopenshell
import ifcopenshell.util.element
import pytest
from rdflib import Literal

from ifc_factory import _gid, write_test_building
from ifc_traits import write_mass_unit, write_traits, write_unnamed_sets
from kbplanner.cli import main
from kbplanner.core.vocab import KBP
from kbplanner.model.project_data import ProjectData
from kbplanner.scale.project_init import InitResult, init_project

SHARED = Path("/work/shared/data/ifc")


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _files(root: Path) -> dict[str, bytes]:
    return {
        str(p.relative_to(root)): p.read_bytes()
        for p in sorted(root.rglob("*"))
        if p.is_file() and ".kbplanner-cache" not in p.parts and p.name != ".kbplanner-run"
    }


@pytest.fixture(scope="module")
def building(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str, InitResult]:
    tmp = tmp_path_factory.mktemp("init")
    ifc = tmp / "house.ifc"
    write_test_building(ifc)
    before = _sha(ifc)
    result = init_project(ifc, tmp / "proj", check_plan=False)
    return ifc, before, result


def test_init_writes_a_project_whose_scenarios_validate(
    building: tuple[Path, str, InitResult], capsys: pytest.CaptureFixture[str]
) -> None:
    ifc, before, r = building
    assert r.written and _sha(ifc) == before  # the input IFC is only read
    assert [w.name for w in r.chosen] == ["Interior partition L1 p1"]
    assert len(r.frames) == 7 and all(9.0 < f.mass_kg < 14.0 for f in r.frames)
    assert set(r.scenarios) == {"storage-inside", "storage-outside"}
    for name in r.scenarios:
        assert main(["validate", str(r.directory), "--scenario", name]) == 0
        capsys.readouterr()
        assert main(["requirements", str(r.directory), "--scenario", name]) == 0
        out = capsys.readouterr().out
        assert "Additional modeling requirements" not in out and "Already in the model" in out
    # every wall not chosen has its reason
    assert all(w.reason for w in r.walls if not w.chosen)
    # the bare model lacks what the scenarios add (the paper's two requirements): exit 1, naming the way
    assert main(["validate", str(r.directory)]) == 1
    err = capsys.readouterr().err
    assert "This was the bare model" in err and f"--scenario {min(r.scenarios)}" in err
    # --scenario all: the project as it will be simulated, every scenario in turn
    assert main(["validate", str(r.directory), "--scenario", "all"]) == 0
    out = capsys.readouterr().out
    assert all(f"== scenario {name}" in out for name in r.scenarios) and "every scenario conforms" in out
    report = str(r.directory / "r.ttl")
    assert main(["validate", str(r.directory), "--scenario", "all", "--report", report]) == 2
    assert not (r.directory / "r.ttl").exists()


def test_frames_are_in_the_ifc_copy_with_mass_and_grasp_points(
    building: tuple[Path, str, InitResult],
) -> None:
    _ifc, _before, r = building
    copy = ifcopenshell.open(str(next((r.directory / "model").glob("*_frames.ifc"))))
    members = {m.GlobalId: m for m in copy.by_type("IfcMember")}
    assert set(members) == {f.global_id for f in r.frames}
    for f in r.frames:
        psets = ifcopenshell.util.element.get_psets(members[f.global_id])
        assert psets["BaseQuantities"]["NetWeight"] == pytest.approx(f.mass_kg)
        assert psets["Kbplanner_StudFramePanel"]["HostWallGlobalId"] == f.spot.wall
        assert psets["Kbplanner_StudFramePanel"]["GraspPointZ"] == pytest.approx(f.centre_of_mass_local[2])
    data = ProjectData.load(r.directory, scenario="storage-inside")
    for f in r.frames:
        node = data.model.value(predicate=KBP.globalId, object=Literal(f.global_id))
        assert float(data.model.value(node, KBP.mass)) == pytest.approx(f.mass_kg, abs=0.01)
        assert data.model.value(node, KBP.graspPoint) is not None
        assert data.model.value(node, KBP.storedIn) is not None


def test_init_is_deterministic(building: tuple[Path, str, InitResult], tmp_path: Path) -> None:
    ifc, _before, r = building
    again = init_project(ifc, tmp_path / "again", check_plan=False)
    assert _files(again.directory) == _files(r.directory)


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--task", "paint-walls"], ["frame-interior-walls", "I-W-F-#1"]),
        (["--task", "L-M-#1"], ["frame-interior-walls", "no derivation"]),
        (["--storey", "Level 9"], ["Level 1", "Level 2"]),
        (["--walls", "No such wall"], ["--walls", "No such wall"]),
    ],
)
def test_bad_options_exit_2_naming_the_fix(
    building: tuple[Path, str, InitResult],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    args: list[str],
    words: list[str],
) -> None:
    ifc = building[0]
    assert main(["init", str(ifc), "--out", str(tmp_path / "p"), *args]) == 2
    err = capsys.readouterr().err
    assert "fix:" in err and all(w in err for w in words) and "Traceback" not in err
    assert not (tmp_path / "p").exists()


def test_a_foreign_folder_is_refused(
    building: tuple[Path, str, InitResult], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "mine"
    out.mkdir()
    (out / "notes.txt").write_text("keep me")
    assert main(["init", str(building[0]), "--out", str(out)]) == 2
    assert (out / "notes.txt").read_text() == "keep me" and len(list(out.iterdir())) == 1
    assert "fix:" in capsys.readouterr().err


def test_no_qualifying_wall_exits_1_with_reasons_and_writes_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    ifc = tmp_path / "one_bay.ifc"
    write_test_building(ifc, bays=1, storeys=1)  # four exterior walls, no partition
    assert main(["init", str(ifc), "--out", str(tmp_path / "p")]) == 1
    out = capsys.readouterr().out
    assert out.count("external wall (Pset_WallCommon.IsExternal = true)") == 4
    assert "Negative result" in out and not (tmp_path / "p").exists()
    assert "--walls GlobalId" in out  # the way in: name the walls


def test_walls_named_in_walls_are_framed_although_pset_says_external(tmp_path: Path) -> None:
    """A model whose walls are all IsExternal (Revit's exterior wall types, the public models): --walls."""
    ifc = tmp_path / "one_bay.ifc"
    write_test_building(ifc, bays=1, storeys=1)
    west = _gid("wall-0-west")
    r = init_project(ifc, tmp_path / "p", walls=[west], check_plan=False)
    assert r.written and [c.global_id for c in r.chosen] == [west] and r.frames
    assert any(west in n and "named in --walls although external wall" in n for n in r.notes)


@pytest.mark.parametrize(
    "writer",
    [
        lambda p: write_unnamed_sets(p, "IFC2X3"),  # unnamed psets, IFC2X3
        lambda p: write_mass_unit(p, "gram", 13630.0),  # mass in grams
        write_traits,  # split-level slab, door without host wall, storey without spaces, stairs
    ],
    ids=["unnamed-psets-ifc2x3", "gram", "traits"],
)
def test_traits_give_a_valid_project(tmp_path: Path, writer: Callable[[Path], object]) -> None:
    ifc = tmp_path / "t.ifc"
    writer(ifc)
    r = init_project(ifc, tmp_path / "p", max_walls=2, check_plan=False)
    assert r.written and r.frames and r.scenarios
    name = next(iter(r.scenarios))
    assert main(["validate", str(r.directory), "--scenario", name]) == 0
    data = ProjectData.load(r.directory, scenario=name)
    masses = sorted(
        float(
            data.model.value(data.model.value(predicate=KBP.globalId, object=Literal(f.global_id)), KBP.mass)
        )
        for f in r.frames
    )
    assert masses == pytest.approx(sorted(f.mass_kg for f in r.frames), abs=0.01)  # kilograms, any unit


@pytest.mark.slow
@pytest.mark.skipif(not (SHARED / "Duplex_A_20110907.ifc").is_file(), reason="shared Duplex not present")
def test_duplex(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["init", str(SHARED / "Duplex_A_20110907.ifc"), "--out", str(tmp_path / "d")])
    out = capsys.readouterr().out
    assert "walls chosen: 4 of 57; frames: 14" in out
    planned = [int(n) for n in re.findall(r"plan \(B1-B4\): (\d+) of 14 frames installable", out)]
    assert len(planned) == 2  # both scenarios planned as `kbplanner plan` plans them
    failing = 28 - sum(planned)
    assert code == (1 if failing else 0) and out.count("      fix: ") == failing  # each with its fix
    for name in ("storage-inside", "storage-outside"):
        assert main(["validate", str(tmp_path / "d"), "--scenario", name]) == 0


@pytest.mark.slow
@pytest.mark.parametrize("model", ["IfcOpenHouse_IFC4.ifc", "example.ifc"])
def test_public_models_without_partitions_exit_1_with_reasons(
    tmp_path: Path, model: str, capsys: pytest.CaptureFixture[str]
) -> None:
    path = SHARED / "public" / model
    if not path.is_file():
        pytest.skip(f"{path} not present")
    assert main(["init", str(path), "--out", str(tmp_path / "p")]) == 1
    out = capsys.readouterr().out
    walls = len(ifcopenshell.open(str(path)).by_type("IfcWall"))
    assert f"walls chosen: 0 of {walls}" in out and "Negative result" in out


def test_an_ifc2x3_copy_is_byte_identical_on_a_rerun(tmp_path: Path) -> None:
    """IFC2X3 needs owner histories: the file's own is reused, none with a time stamp is added."""
    ifc = tmp_path / "x3.ifc"
    write_test_building(ifc, schema="IFC2X3", storeys=1)
    one = init_project(ifc, tmp_path / "one", max_walls=1, check_plan=False)
    two = init_project(ifc, tmp_path / "two", max_walls=1, check_plan=False)
    assert one.frames and _files(one.directory) == _files(two.directory)
    copy = ifcopenshell.open(str(next((one.directory / "model").glob("*.ifc"))))
    assert len(copy.by_type("IfcOwnerHistory")) == len(ifcopenshell.open(str(ifc)).by_type("IfcOwnerHistory"))


def test_an_upper_storey_gets_a_robot_arrival_and_an_inside_storage(building: tuple[Path, str, InitResult],
                                                                     tmp_path: Path) -> None:
    from kbplanner.world.build import world_of

    r = init_project(building[0], tmp_path / "up", storey="Level 2", check_plan=False)
    assert r.storey == "Level 2" and r.frames and set(r.scenarios) == {"storage-inside"}
    assert any("robot arrival" in n for n in r.notes)
    assert main(["validate", str(r.directory), "--scenario", "storage-inside"]) == 0
    world = world_of(ProjectData.load(r.directory, scenario="storage-inside"), task_id="T-FRAME")
    assert world.robot_start is not None and world.robot_start.z == pytest.approx(3.0)  # on Level 2


def test_an_ifc_work_schedule_is_named_in_a_note(tmp_path: Path) -> None:
    import ifcopenshell.api.sequence as seq

    ifc = tmp_path / "sched.ifc"
    write_test_building(ifc, storeys=1)
    f = ifcopenshell.open(str(ifc))
    ws = seq.add_work_schedule(f, name="Construction")
    seq.add_task(f, work_schedule=ws, name="Partitions", identification="P1")
    f.write(str(ifc))
    r = init_project(ifc, tmp_path / "p", max_walls=1, check_plan=False)
    assert r.written and any("work schedule (1 IfcTask)" in n for n in r.notes)


def test_a_storey_without_walls_or_spaces_is_a_negative_result(tmp_path: Path,
                                                               capsys: pytest.CaptureFixture[str]) -> None:
    ifc = tmp_path / "traits.ifc"
    write_traits(ifc)  # "Level 3": one slab, no walls, no spaces
    assert main(["init", str(ifc), "--storey", "Level 3", "--out", str(tmp_path / "p")]) == 1
    out = capsys.readouterr().out
    assert "storey Level 3" in out and "walls chosen: 0 of 12" in out and "not the task storey Level 3" in out
    assert not (tmp_path / "p").exists()
