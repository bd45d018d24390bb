"""B5 navigation: the reversing cost (``kbp:reversingCost``, seconds of drive time one metre less driven
backwards is worth, under monitoring) is a parameter of the navigation skills in Turtle: 0 (off) by default
in the knowledge base, set per action by a task specification's setting, checked where it is read."""

from __future__ import annotations

import math

import pytest
from rdflib import Graph

from kbplanner.core.errors import KbplannerError
from kbplanner.knowledge.jobsite import action_parameters
from kbplanner.knowledge.knowledge_base import load_kb
from kbplanner.knowledge.task_specs import task_specification
from kbplanner.simulation.back_out import reversing_cost

SETTING = """
@prefix kb: <https://w3id.org/kbplanner/kb#> .
@prefix kbp: <https://w3id.org/kbplanner/ontology#> .
kb:I-W-F-2-a3 kbp:hasSetting kb:I-W-F-2-a3-reversing .
kb:I-W-F-2-a3-reversing a kbp:ParameterSetting ; kbp:setsParameter kb:NV-2-reversingCost ; kbp:value 8.0 .
"""


def _values(kb: Graph, spec_id: str) -> dict[tuple[int, str], object]:
    return {(ap.action.order, p.name): p.value
            for ap in action_parameters(task_specification(kb, spec_id), None) for p in ap.parameters}


def test_the_knowledge_base_gives_both_navigation_skills_a_reversing_cost_of_zero() -> None:
    v = _values(load_kb(), "I-W-F-#1")
    assert v[(1, "reversingCost")] == 0.0 and v[(3, "reversingCost")] == 0.0  # NV-1, NV-2


def test_a_task_specification_sets_it_in_turtle_for_one_action() -> None:
    kb = load_kb()
    kb.parse(data=SETTING, format="turtle")
    v = _values(kb, "I-W-F-#2")
    assert v[(3, "reversingCost")] == 8.0 and v[(1, "reversingCost")] == 0.0
    assert reversing_cost(v[(3, "reversingCost")]) == 8.0


@pytest.mark.parametrize("value", [-1.0, math.inf, math.nan, "fast", True])
def test_a_value_that_is_not_a_finite_number_of_at_least_zero_is_refused_with_the_fix(value: object) -> None:
    with pytest.raises(KbplannerError) as err:
        reversing_cost(value)
    assert "kbp:reversingCost" in str(err.value) and ">= 0" in str(err.value)


def test_no_value_is_off() -> None:
    assert reversing_cost(None) == 0.0 and reversing_cost(0) == 0.0
