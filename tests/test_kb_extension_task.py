"""Issue 12: a new task type written only in Turtle, from the documented skill kinds, runs end to end.

``tests/kb_extension/panel_inspection.ttl`` adds a task kind, a model property (a viewpoint), a skill
of kind kbp:Inspect and a two-action specification INS-#1 (NV-1 to the viewpoint, look at the panel).
On the small executor test building (two panels standing, a robotized inspection task over them),
with no Python change, it derives its requirement, validates, selects a robot, plans and simulates;
a kind outside the set and a role the kind cannot use stop the CLI with exit 2 before simulating.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from kbplanner.cli import main
from kbplanner.core.errors import KnowledgeBaseError
from kbplanner.project import Project
from sim_project_factory import BASE, PANELS, make_sim_project

EXTENSION = Path(__file__).parent / "kb_extension" / "panel_inspection.ttl"
ANCHORS = Path(__file__).parent / "kb_extension" / "anchor_fastening.ttl"
DATE = "2022-05-20T08:00:00"
SCHEDULE = """task_id,name,start,finish,predecessors,elements,robotized,task_specification
T1,Slabs,2022-03-01,2022-03-05,,class=IfcSlab,false,
T2,Walls,2022-03-06,2022-03-15,T1,class=IfcWall,false,
T3,Doors,2022-03-16,2022-03-18,T2,class=IfcDoor,false,
T5,Panels,2022-05-10,2022-05-12,T3,class=IfcMember,false,
T6,Inspect panels,2022-05-20,2022-05-20,T5,class=IfcMember,true,INS-#1
"""


def _project(directory: Path, extension: Path = EXTENSION, spec: str = "INS-#1") -> Path:
    sp = make_sim_project(directory, high_panel=False)
    (directory / "schedule.csv").write_text(SCHEDULE.replace("INS-#1", spec), encoding="utf-8")
    lines = ["@prefix kbp: <https://w3id.org/kbplanner/ontology#> .",
             "@prefix ext: <https://example.org/kb-extension#> ."]
    for name, x, y, _z, _yaw in PANELS:
        if name not in sp.panels:
            continue
        pose = f"<{BASE}pose/view-{name}>"
        lines += [f"<{sp.iri(name)}> ext:viewpoint {pose} .",
                  f"{pose} a kbp:Pose ; kbp:x {x} ; kbp:y {y - 1.6} ; kbp:z 0.0 ; kbp:yaw {math.pi / 2} ."]
    (directory / "viewpoints.ttl").write_text("\n".join(lines) + "\n", encoding="utf-8")
    toml = (directory / "project.toml").read_text(encoding="utf-8")
    toml = toml.replace('task = "T5"', 'task = "T6"').replace("2022-05-10T08:00:00", DATE)
    toml = toml.replace('site = ["site.ttl"]', f'site = ["site.ttl"]\nknowledge_base = ["{extension}"]')
    toml += '[scenarios.viewpoints]\ndescription = "a viewpoint per panel"\noverlays = ["viewpoints.ttl"]\n'
    (directory / "project.toml").write_text(toml, encoding="utf-8")
    return directory


def test_a_turtle_only_task_type_goes_from_requirements_to_simulation(tmp_path: Path) -> None:
    d = _project(tmp_path / "proj")
    bare = Project.load(d)
    [req] = bare.requirements().requirements
    assert (req.task_id, req.skill_id, len(req.elements)) == ("T6", "NV-1", 2)
    # the test building's site Turtle has plain decimals (well-formedness warnings of its own):
    # look only at the rows of the requirement shape
    assert [r.focus for r in bare.validate().violations if "viewpoint" in r.path + r.message] != []
    project = Project.load(d, scenario="viewpoints")
    assert [r for r in project.validate().violations if "viewpoint" in r.path + r.message] == []
    sel = project.select_robots()
    assert {a.robot.label for a in sel.fit} >= {"Clearpath Husky A200 + UR5"}
    assert all(any("RGB-D camera" in r.message for r in a.reasons) for a in sel.assessments
               if a.robot.label == "Clearpath Jackal")
    plan = project.plan()
    assert plan.spec_id == "INS-#1" and plan.feasible and len(plan.steps) == 4
    assert plan.steps[1].roles == {"ViewTargetRole": "what to look at", "WorkElementRole": "the panel"}
    assert plan.steps[1].parameters["dwellTime"] == 2.0
    result = project.simulate(plan, out_dir=tmp_path / "run")
    assert result.all_installed, [e.reason for e in result.elements]
    looks = [s for e in result.elements for s in e.steps if s.skill_id == "IN-1"]
    assert len(looks) == 2 and all(s.duration_s >= 2.0 for s in looks)
    assert all(0.5 < s.details["distance_m"] < 4.0 for s in looks)
    events = (tmp_path / "run" / "events.jsonl").read_text()
    assert events.count('"kind": "inspect"') == 2


@pytest.mark.parametrize(("old", "new", "words"), [
    ("kbp:skillKind kbp:Inspect", "kbp:skillKind ext:Photographing",
     ["IN-1", "ext:Photographing", "kbp:Inspect", "kbp:FollowToolPath", "panel_inspection.ttl"]),
    ("kbp:inputRole kbp:ViewTargetRole", "kbp:inputRole kbp:ToolPathRole",
     ["input 'what to look at' of skill IN-1", "kbp:ToolPathRole", "kbp:ViewTargetRole"]),
])
def test_a_kind_outside_the_set_or_an_unusable_role_stops_the_cli_with_exit_2(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], old: str, new: str, words: list[str]) -> None:
    bad = tmp_path / "panel_inspection.ttl"
    text = EXTENSION.read_text(encoding="utf-8").replace(old, new)
    bad.write_text(text + "\next:Photographing a kbp:SkillKind .\n", encoding="utf-8")
    d = _project(tmp_path / "proj", extension=bad)
    with pytest.raises(KnowledgeBaseError):
        Project.load(d, scenario="viewpoints").plan()
    assert main(["simulate", str(d), "--scenario", "viewpoints", "--no-keyframes",
                 "--out", str(tmp_path / "run")]) == 2
    err = capsys.readouterr().err
    for w in words:
        assert w in err
    assert not (tmp_path / "run").exists()


def _tool_pose_ahead(base: tuple[float, float, float]) -> list[float]:
    """Where the UR5's tool is in its named pre-grasp pose with the Husky at ``base`` (x, y, yaw)."""
    import pybullet as pb

    from kbplanner.robot.robot_model import RobotModel

    robot = RobotModel.load("husky_ur5", pose=base)
    try:
        robot.set_named_pose("pre_grasp")
        pos, quat = robot.tool_pose()
        return [*pos, *pb.getEulerFromQuaternion(quat)]
    finally:
        robot.close()


@pytest.mark.parametrize(("force", "ok"), [(30.0, True), (80.0, False)])
def test_a_turtle_only_fastening_task_holds_the_tool_pose_for_its_dwell_time(
        tmp_path: Path, force: float, ok: bool) -> None:
    kb_file = tmp_path / "anchor_fastening.ttl"
    kb_file.write_text(ANCHORS.read_text(encoding="utf-8").replace(
        "kbp:contactForce ; kbp:defaultValue 30.0", f"kbp:contactForce ; kbp:defaultValue {force}"),
        encoding="utf-8")
    d = _project(tmp_path / "proj", extension=kb_file, spec="ANC-#1")
    sp_panels = [(n, x, y) for n, x, y, _z, _yaw in PANELS[:2]]
    lines = ["@prefix kbp: <https://w3id.org/kbplanner/ontology#> .",
             "@prefix ext: <https://example.org/kb-extension#> ."]
    project0 = Project.load(d)
    gids = {e.label: e for e in project0.plan(refine=False).elements}
    for name, x, y in sp_panels:
        base = (x, y - 1.6, math.pi / 2)
        tool = _tool_pose_ahead(base)
        el = next(e.iri for label, e in gids.items() if label.endswith(name))
        lines += [f"<{el}> ext:workPose <{BASE}pose/work-{name}> ;",
                  f"    ext:anchorPose <{BASE}pose/anchor-{name}> .",
                  f"<{BASE}pose/work-{name}> a kbp:Pose ; kbp:x {base[0]} ; kbp:y {base[1]} ; kbp:z 0.0 ; "
                  f"kbp:yaw {base[2]} .",
                  f"<{BASE}pose/anchor-{name}> a kbp:Pose ; kbp:x {tool[0]} ; kbp:y {tool[1]} ; "
                  f"kbp:z {tool[2]} ; "
                  f"kbp:roll {tool[3]} ; kbp:pitch {tool[4]} ; kbp:yaw {tool[5]} ."]
    (d / "viewpoints.ttl").write_text("\n".join(lines) + "\n", encoding="utf-8")
    project = Project.load(d, scenario="viewpoints")
    plan = project.plan(robot_id="husky-ur5")
    assert plan.feasible and [s.skill_id for s in plan.steps] == ["NV-1", "AN-1"] * 2
    result = project.simulate(plan, out_dir=tmp_path / "run")
    sets = [s for e in result.elements for s in e.steps if s.skill_id == "AN-1"]
    if ok:
        assert result.all_installed, [e.reason for e in result.elements]
        assert all(s.duration_s >= 1.5 and s.details["force_n"] == 30.0 for s in sets)
        assert (tmp_path / "run" / "events.jsonl").read_text().count('"kind": "fasten"') == 2
    else:
        assert not result.all_installed
        why = "contact force 80 N is more than the arm's payload of 5 kg"
        assert all(why in (s.reason or "") for s in sets)


def test_the_shipped_layout_marking_draws_each_line_at_the_tool_speed(tmp_path: Path) -> None:
    """L-M-#1 (NV-1 + MK-1, kind kbp:FollowToolPath) on the small building: the panels' axes are marked
    before the panels stand (a specification without a pick has targets, not material)."""
    from kbplanner.analysis.work_done import work_done

    d = _project(tmp_path / "proj", spec="L-M-#1")
    schedule = (d / "schedule.csv").read_text(encoding="utf-8")
    schedule = schedule.replace("2022-05-20,2022-05-20", "2022-05-05,2022-05-05")
    (d / "schedule.csv").write_text(schedule.replace(",T5,class=IfcMember,true", ",T3,class=IfcMember,true"),
                                    encoding="utf-8")
    toml = (d / "project.toml").read_text(encoding="utf-8").replace(DATE, "2022-05-05T08:00:00")
    (d / "project.toml").write_text(toml, encoding="utf-8")
    project0 = Project.load(d)
    lines = ["@prefix kbp: <https://w3id.org/kbplanner/ontology#> ."]
    for e in project0.plan(refine=False).elements:
        x = e.installed_pose.x - 0.3  # the panel's axis runs 0.3 m either side of its origin, along x
        lines += [f"<{e.iri}> kbp:markingStart <{e.iri}-start> .",
                  f"<{e.iri}-start> a kbp:Pose ; kbp:x {x} ; kbp:y {e.installed_pose.y} ; kbp:z 0.0 ; "
                  "kbp:yaw 0.0 ."]
    lines += [f"<{BASE}task/T6> kbp:surveyReference <{BASE}pose/control> .",
              f"<{BASE}pose/control> a kbp:Pose ; kbp:x 0.0 ; kbp:y 0.0 ; kbp:z 0.0 ."]
    (d / "viewpoints.ttl").write_text("\n".join(lines) + "\n", encoding="utf-8")
    project = Project.load(d, scenario="viewpoints")
    assert project.world().task_elements == ()  # targets, not material at a storage
    plan = project.plan()
    assert plan.robot_id == "jackal-marker" and plan.feasible
    assert plan.steps[1].roles["ToolPathRole"] == "footprint"
    result = project.simulate(plan, out_dir=tmp_path / "run")
    assert result.all_installed, [e.reason for e in result.elements]
    marks = [s for e in result.elements for s in e.steps if s.skill_id == "MK-1"]
    assert [s.details["line_length_m"] for s in marks] == [0.6, 0.6]
    assert all(s.details["marked_m"] == pytest.approx(0.6, abs=0.01) and s.details["unreachable_m"] == 0.0
               for s in marks)
    assert all(s.duration_s >= 0.6 / 0.2 for s in marks)  # MK-1's tool speed, 0.2 m/s
    events = (tmp_path / "run" / "events.jsonl").read_text()
    assert events.count('"kind": "tool_down"') == 2 and events.count('"kind": "tool_up"') == 2
    import json

    metrics = json.loads((tmp_path / "run" / "metrics.json").read_text())
    assert work_done(metrics) == "marked 1.20 m of 1.20 m of lines"
