"""Jobsite parameters (A5): they override the skill defaults of each action in a documented order,
per project or scenario, and contradictory values are errors naming the jobsite term."""

from __future__ import annotations

import pytest
from rdflib import RDF, Graph, Literal

from kb_fixtures import BASE, add_jobsite, make_model
from kbplanner.core.iris import mint
from kbplanner.core.vocab import KBP
from kbplanner.knowledge.jobsite import JobsiteError, action_parameters, jobsite_parameters
from kbplanner.knowledge.knowledge_base import KB, load_kb
from kbplanner.knowledge.task_specs import task_specification


@pytest.fixture(scope="module")
def kb() -> Graph:
    return load_kb()


def _values(kb: Graph, spec_id: str, model: Graph | None, scenario: str | None = None
            ) -> dict[tuple[int, str], object]:
    js = jobsite_parameters(model, scenario) if model is not None else None
    return {(ap.action.order, p.name): p.value
            for ap in action_parameters(task_specification(kb, spec_id), js) for p in ap.parameters}


def test_without_jobsite_parameters_actions_use_the_skill_defaults(kb: Graph) -> None:
    v = _values(kb, "I-W-F-#1", None)
    assert v[(1, "maxSpeed")] == 0.5 and v[(1, "minSpeed")] == 0.1 and v[(1, "safetyStopDistance")] == 0.5
    assert v[(3, "maxSpeed")] == 0.3 and v[(3, "armPose")] == KB["pose-carry"]
    assert v[(2, "approachPose")] == KB["pose-pick-approach"]


def test_action_settings_of_the_specification_override_skill_defaults(kb: Graph) -> None:
    v = _values(kb, "I-W-F-#2", None)
    assert v[(3, "maxSpeed")] == 0.2 and v[(3, "safetyStopDistance")] == 1.5
    assert v[(3, "armPose")] == KB["pose-carry-on-side"]


def test_jobsite_values_apply_per_skill_and_site_wide_with_their_source(kb: Graph) -> None:
    model = make_model(n_frames=2, jobsite=True)  # NV-2 limit 0.1..0.4 m/s, site-wide stop distance 0.8 m
    aps = action_parameters(task_specification(kb, "I-W-F-#1"), jobsite_parameters(model))
    nv2 = {p.name: p for p in aps[2].parameters}
    # the limit's 0.4 m/s is a maximum: NV-2's own 0.3 m/s stays; its minimum 0.1 replaces 0.05
    assert (nv2["minSpeed"].value, nv2["maxSpeed"].value) == (0.1, 0.3)
    assert "jobsite limit" in nv2["minSpeed"].source and "for NV-2" in nv2["minSpeed"].source
    assert nv2["maxSpeed"].source == "default of skill NV-2"
    # a site-wide stop distance is a minimum: NV-1 (0.5 m) is raised, NV-2 (1.0 m) keeps its own
    assert aps[0].value(KBP.safetyStopDistance) == 0.8 and aps[2].value(KBP.safetyStopDistance) == 1.0
    assert "site-wide minimum" in next(p.source for p in aps[0].parameters if p.name == "safetyStopDistance")


def test_a_site_wide_maximum_speed_caps_every_action(kb: Graph) -> None:
    model = make_model(n_frames=2)
    js = add_jobsite(model)
    model.add((js, KBP.maxSpeed, Literal(0.25)))
    v = _values(kb, "I-W-F-#1", model)
    assert v[(1, "maxSpeed")] == 0.25  # NV-1 0.5 capped
    assert v[(3, "maxSpeed")] == 0.25  # the NV-2 limit (0.4) does not raise the site-wide cap


def test_a_limit_on_one_action_beats_a_limit_on_its_skill(kb: Graph) -> None:
    model = make_model(n_frames=2)
    js = add_jobsite(model)
    lim = mint(BASE, "site", "jobsite-action-limit")
    model.add((js, KBP.hasActionLimit, lim))
    model.add((lim, RDF.type, KBP.ActionLimit))
    model.add((lim, KBP.appliesTo, KB["I-W-F-2-a3"]))
    model.add((lim, KBP.maxSpeed, Literal(0.15)))
    v = _values(kb, "I-W-F-#2", model)
    assert v[(3, "maxSpeed")] == 0.15 and v[(3, "minSpeed")] == 0.1


def test_a_limit_caps_a_slower_action_setting_and_never_raises_it(kb: Graph) -> None:
    # issue 12: an action setting of 0.25 m/s ran at 0.3 because the limit replaced it
    model = make_model(n_frames=2)
    add_jobsite(model, max_speed=0.3)  # a limit for NV-2: at most 0.3 m/s
    aps = action_parameters(task_specification(kb, "I-W-F-#2"), jobsite_parameters(model))
    carry = {p.name: p for p in aps[2].parameters}
    assert carry["maxSpeed"].value == 0.2 and carry["maxSpeed"].source == "action 3 of I-W-F-#2"
    assert carry["safetyStopDistance"].value == 1.5  # the action's 1.5 m is above the site minimum 0.8
    model = make_model(n_frames=2)
    add_jobsite(model, max_speed=0.15)
    aps = action_parameters(task_specification(kb, "I-W-F-#2"), jobsite_parameters(model))
    carry = {p.name: p for p in aps[2].parameters}
    assert carry["maxSpeed"].value == 0.15 and "limit cap" in carry["maxSpeed"].source


def test_a_scenario_node_overrides_the_project_wide_node(kb: Graph) -> None:
    model = make_model(n_frames=2)
    add_jobsite(model, max_width=0.8)
    add_jobsite(model, max_width=0.7, max_speed=0.25, scenario="storage-inside")
    assert jobsite_parameters(model).max_robot_width_m == 0.8
    inside = jobsite_parameters(model, "storage-inside")
    assert inside.max_robot_width_m == 0.7 and len(inside.nodes) == 2
    assert _values(kb, "I-W-F-#1", model, "storage-inside")[(3, "maxSpeed")] == 0.25
    assert _values(kb, "I-W-F-#1", model)[(3, "maxSpeed")] == 0.3


def test_no_go_zones_are_read_with_their_size(kb: Graph) -> None:
    [zone] = jobsite_parameters(make_model(n_frames=1, jobsite=True)).no_go_zones
    got = (zone.label, zone.x, zone.y, zone.size_x, zone.size_y)
    assert got == ("Crane swing area", -10.0, -10.0, 4.0, 4.0)


def test_an_effective_minimum_speed_above_the_maximum_is_an_error_naming_both_sources(kb: Graph) -> None:
    model = make_model(n_frames=2)
    js = add_jobsite(model)
    model.add((js, KBP.minSpeed, Literal(0.45)))  # site-wide, replaces NV-1's minimum; NV-1 max is 0.5
    model.add((js, KBP.maxSpeed, Literal(0.3)))  # caps NV-1's maximum to 0.3
    with pytest.raises(JobsiteError) as err:
        action_parameters(task_specification(kb, "I-W-F-#1"), jobsite_parameters(model))
    text = str(err.value)
    assert "action 1 'navigate to frame pickup location' of I-W-F-#1 (NV-1)" in text
    assert "minimum speed 0.45 m/s above its maximum speed 0.3 m/s" in text
    assert str(js) in text and "fix:" in text


def test_two_project_wide_values_for_one_limit_are_an_error(kb: Graph) -> None:
    model = make_model(n_frames=1)
    add_jobsite(model, max_width=0.8)
    other = mint(BASE, "site", "jobsite-2")
    model.add((other, RDF.type, KBP.JobsiteParameters))
    model.add((other, KBP.maxRobotWidth, Literal(0.9)))
    with pytest.raises(JobsiteError, match="kbp:maxRobotWidth is given twice with different values"):
        jobsite_parameters(model)
