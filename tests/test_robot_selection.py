"""Robot selection (B3 preview): every robot of the knowledge base, fit or not, with every reason."""

from __future__ import annotations

from pathlib import Path

import pytest
from rdflib import Graph, Literal

from kb_fixtures import add_jobsite, frame_gid, make_model
from kbplanner.core.errors import KbplannerError, KnowledgeBaseError
from kbplanner.core.vocab import KBP
from kbplanner.knowledge.knowledge_base import KB, load_kb
from kbplanner.knowledge.robot_selection import CAPABILITY, DOOR, PAYLOAD, SITE, load_robots, select_robots


@pytest.fixture(scope="module")
def kb() -> Graph:
    return load_kb()


def _verdicts(model: Graph, kb: Graph, task: str = "T1") -> dict[str, tuple[bool, list[str]]]:
    sel = select_robots(model, kb, task)
    return {a.robot.label: (a.fit, [r.check for r in a.reasons]) for a in sel.assessments}


def test_the_knowledge_base_has_four_robots_with_sourced_figures(kb: Graph) -> None:
    robots = {r.iri: r for r in load_robots(kb)}
    assert set(robots) == {KB["husky-ur5"], KB["husky-ur16e"], KB["jackal"], KB["jackal-marker"]}
    ur5 = robots[KB["husky-ur5"]]
    assert (ur5.length_m, ur5.width_m, ur5.base_mass_kg, ur5.arm_mass_kg) == (0.99, 0.67, 50.0, 18.4)
    assert (ur5.payload_kg, ur5.reach_m, ur5.max_speed_mps, ur5.urdf, ur5.arm_model) == (
        5.0, 0.85, 1.0, "husky_ur5.urdf", "UR5")
    assert ur5.mass_kg == pytest.approx(68.4)
    assert robots[KB["husky-ur16e"]].payload_kg == 16.0 and robots[KB["husky-ur16e"]].arm_mass_kg == 33.1
    assert KBP.Manipulation6DoF not in robots[KB["jackal"]].capabilities
    assert all(r.sources for r in robots.values())


def test_light_frames_fit_both_husky_arms_and_the_jackal_lacks_an_arm(kb: Graph) -> None:
    v = _verdicts(make_model(storage=True), kb)
    assert v["Clearpath Husky A200 + UR5"] == (True, [])
    assert v["Clearpath Husky A200 + UR16e"] == (True, [])
    fit, reasons = v["Clearpath Jackal"]
    assert not fit and reasons.count(CAPABILITY) == 3 and PAYLOAD in reasons


def test_every_missing_capability_names_the_skill_that_requires_it(kb: Graph) -> None:
    sel = select_robots(make_model(storage=True), kb, "T1")
    jackal = next(a for a in sel.assessments if a.robot.iri == KB["jackal"])
    messages = [r.message for r in jackal.reasons if r.check == CAPABILITY]
    assert "missing capability RGB-D camera (kbp:DepthCamera), required by skill MM-G-1" in messages
    arm = ("missing capability 6-DoF manipulator (kbp:Manipulation6DoF), "
           "required by skill MM-G-1, NV-2, MM-R-1")
    assert arm in messages


def test_frames_heavier_than_the_ur5_payload_rule_it_out_naming_the_heaviest_frame(kb: Graph) -> None:
    sel = select_robots(make_model(storage=True, frame_mass=9.7), kb, "T1")
    assert sel.heaviest is not None and sel.heaviest[0] == 9.7
    ur5 = next(a for a in sel.assessments if a.robot.iri == KB["husky-ur5"])
    [reason] = ur5.reasons
    assert reason.check == PAYLOAD
    assert reason.message == f"payload 5 kg below the heaviest element 9.70 kg ({frame_gid(11)} 'Frame 11')"
    assert [a.robot.label for a in sel.fit] == ["Clearpath Husky A200 + UR16e"]


def test_a_door_narrower_than_the_husky_rules_out_both_huskies(kb: Graph) -> None:
    sel = select_robots(make_model(storage=True, inner_door_width=0.65), kb, "T1")
    assert sel.door is not None and sel.door.width_m == 0.65 and sel.door.door.global_id == "DOOR-INNER"
    for a in sel.assessments:
        if a.robot.iri in (KB["husky-ur5"], KB["husky-ur16e"]):
            assert [r.check for r in a.reasons] == [DOOR]
            assert "0.670 m is wider than the narrowest door it must pass, 0.650 m" in a.reasons[0].message
    assert sel.fit == []


def test_the_exterior_door_counts_when_the_storage_is_outside(kb: Graph) -> None:
    sel = select_robots(make_model(storage=True, front_door_width=0.7), kb, "T1")
    assert sel.door is not None and sel.door.door.global_id == "DOOR-FRONT" and sel.door.width_m == 0.7
    assert "exterior door" in sel.door.why


def test_jobsite_limits_on_robot_size_and_mass_are_reasons(kb: Graph) -> None:
    model = make_model(storage=True)
    add_jobsite(model, max_width=0.6)
    sel = select_robots(model, kb, "T1")
    ur16 = next(a for a in sel.assessments if a.robot.iri == KB["husky-ur16e"])
    assert [r.message for r in ur16.reasons] == ["width 0.67 m over the site's allowable width 0.6 m"]
    assert sum(1 for c in ur16.checks if c.check == SITE) == 4


def test_the_door_clearance_of_the_jobsite_is_added_on_both_sides(kb: Graph) -> None:
    model = make_model(storage=True)
    js = add_jobsite(model)
    model.add((js, KBP.doorClearance, Literal(0.1)))
    sel = select_robots(model, kb, "T1")
    ur5 = next(a for a in sel.assessments if a.robot.iri == KB["husky-ur5"])
    assert [r.check for r in ur5.reasons] == [DOOR]  # 0.67 + 2 x 0.1 > 0.8
    assert "+ 2 x 0.1 m clearance" in ur5.reasons[0].message


def test_layout_marking_needs_a_marking_tool_that_only_the_marking_jackal_has(kb: Graph) -> None:
    sel = select_robots(make_model(storage=True, spec_id="L-M-#1"), kb, "T1")
    assert [a.robot.iri for a in sel.fit] == [KB["jackal-marker"]]
    assert not any(c.check == PAYLOAD for a in sel.assessments for c in a.checks)  # nothing is carried
    for a in sel.assessments:
        if a.robot.iri != KB["jackal-marker"]:
            assert any("floor marking tool" in r.message and "MK-1" in r.message for r in a.reasons)


def test_the_text_report_lists_every_robot_and_reason(kb: Graph) -> None:
    text = select_robots(make_model(storage=True, frame_mass=9.7), kb, "T1").text()
    assert text.count("- Clearpath") == 4 and "NOT FIT" in text and "FIT" in text
    assert "heaviest element: 9.70 kg" in text and "narrowest door to pass: 0.800 m" in text


def test_an_unknown_task_is_a_clear_error(kb: Graph) -> None:
    with pytest.raises(KbplannerError) as err:
        select_robots(make_model(), kb, "T9")
    assert "no robotized task with id 'T9'" in str(err.value) and "T1" in str(err.value)


def test_a_robot_without_required_figures_names_the_file_and_the_figures(tmp_path: Path) -> None:
    ext = tmp_path / "robot.ttl"
    ext.write_text("""@prefix kbp: <https://w3id.org/kbplanner/ontology#> .
@prefix kb: <https://w3id.org/kbplanner/kb#> .
kb:arm-bot a kbp:Robot ; kbp:hasCapability kbp:Manipulation6DoF ;
    kbp:footprintLength 1.0 ; kbp:footprintWidth 0.6 ; kbp:height 1.2 ; kbp:baseMass 40.0 ;
    kbp:maxSpeed 1.0 ; kbp:urdf "arm_bot.urdf" ; kbp:armMass 20.0 .
""", encoding="utf-8")
    with pytest.raises(KnowledgeBaseError) as err:
        load_robots(load_kb([ext]))
    text = str(err.value)
    assert str(ext) in text and "kb:arm-bot" in text
    assert "kbp:payload (kg)" in text and "kbp:reach (m)" in text and "kbp:armModel" in text
