"""Graph stages at building scale (issue 6): shared world tables (A6, B1-B3) and the element index.

On a generated 3 x 2 building: planning every robotized task with one set of world tables gives the
plans of planning each task alone; worlds built from the tables have the states of the SPARQL query
``element_state_at`` at every date; the element index of ``schedule_csv`` gives the rows of its former
property-path formulation.
"""

from __future__ import annotations

from datetime import datetime, timedelta
from pathlib import Path

import pytest
from rdflib import XSD, Literal

from conftest import CASE_STUDY
from kbplanner.core.errors import WorldError
from kbplanner.core.vocab import KBP
from kbplanner.knowledge.task_specs import robotized_tasks
from kbplanner.model.schedule_model import query_text
from kbplanner.planning.planner import plan_task, plan_tasks
from kbplanner.planning.task_and_robot import PlanningError
from kbplanner.project import Project
from kbplanner.scale.building_generator import generate_building
from kbplanner.scale.building_plan import SCENARIO
from kbplanner.world.build import build_world
from kbplanner.world.tables import world_tables
from kbplanner.world.world_types import BUILT, NOT_STARTED, World

# The index as it was written before (a property path from an unbound storey): the reference.
PATH_INDEX = """PREFIX bot: <https://w3id.org/bot#>
PREFIX kbp: <https://w3id.org/kbplanner/ontology#>
PREFIX rdfs: <http://www.w3.org/2000/01/rdf-schema#>
SELECT DISTINCT ?element ?globalId ?ifcClass ?label ?storey ?isExternal
WHERE {
  ?element a bot:Element ; kbp:globalId ?globalId .
  FILTER NOT EXISTS { ?element a kbp:Opening }
  OPTIONAL { ?element kbp:ifcClass ?ifcClass }
  OPTIONAL { ?element rdfs:label ?label }
  OPTIONAL {
    ?storeyNode a bot:Storey ; rdfs:label ?storey ;
        (bot:containsElement|bot:hasSpace/bot:containsElement) ?element .
  }
  OPTIONAL { ?element kbp:isExternal ?isExternal }
}
ORDER BY ?globalId ?element
"""


@pytest.fixture(scope="module")
def b3x2(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("scale") / "b3x2"
    return generate_building(out, storeys=3, units_per_storey=2).directory


@pytest.fixture(scope="module")
def project(b3x2: Path) -> Project:
    return Project.load(b3x2, scenario=SCENARIO)


def _states(world: World) -> dict[str, str]:
    """State of every static or absent element of the world (open doors carry none)."""
    out = {e.iri: e.state for e in world.static}
    out.update({o.iri: o.state for o in world.omitted})
    return out


def test_plans_of_every_task_equal_the_plans_of_each_task_alone(project: Project) -> None:
    ids = [t.task_id for t in robotized_tasks(project.model)]
    assert len(ids) == 3
    together = plan_tasks(project)
    alone = [plan_task(project, task_id) for task_id in ids]
    assert [p.task_id for p in together] == ids
    assert all(p.steps and p.feasible for p in together)
    assert [p.to_json() for p in together] == [p.to_json() for p in alone]
    # a subset, in the order given, is the same too
    assert [p.to_json() for p in plan_tasks(project, ids[::-2])] == [alone[2].to_json(), alone[0].to_json()]


def test_plan_tasks_refuses_an_unknown_task_naming_the_robotized_ones(project: Project) -> None:
    with pytest.raises(PlanningError, match="T-FRAME-L01"):
        plan_tasks(project, ["T-FRAME-L01", "T-NOPE"])


@pytest.mark.slow  # about 27 s: `make test-slow` (.ci/run runs it after `make test`)
def test_worlds_from_tables_have_the_states_of_element_state_at_at_every_date(project: Project) -> None:
    tables = world_tables(project)
    rows = project.query("tasks_and_elements").rows
    starts = sorted({r[3] for r in rows if r[3] is not None})
    finishes = sorted({r[4] for r in rows if r[4] is not None})
    dates = [starts[0] - timedelta(days=1), *starts, *(f + timedelta(seconds=1) for f in finishes[::3])]
    seen: set[str] = set()
    for at in dates:
        world = build_world(project, at, "T-FRAME-L02", tables=tables)
        assert world == build_world(project, at, "T-FRAME-L02")
        expected = project.element_states(at)
        for iri, state in _states(world).items():
            assert state == expected.get(iri, BUILT), (at, iri)
            seen.add(state)
        assert {d.iri for d in world.open_doors}.isdisjoint(
            {iri for iri, state in expected.items() if state == NOT_STARTED})
    assert seen == {"built", "in progress", "not started"}


def test_a_schedule_time_with_a_time_zone_is_judged_by_sparql(b3x2: Path) -> None:
    project = Project.load(b3x2, scenario=SCENARIO)
    task = next(project.model.subjects(KBP.taskId, Literal("T-FRAME-L01")))
    project.model.set((task, KBP.finish, Literal("2024-03-29T17:00:00+02:00", datatype=XSD.dateTime)))
    tables = world_tables(project)
    assert tables.schedule is None
    at = datetime(2024, 3, 26, 7)
    world = build_world(project, at, "T-FRAME-L02", tables=tables)
    expected = project.element_states(at)
    for e in world.static:
        assert e.state == expected.get(e.iri, BUILT)
    assert any(o.state == NOT_STARTED for o in world.omitted)


def test_tables_of_another_project_are_refused(project: Project, b3x2: Path) -> None:
    other = Project.load(b3x2, scenario=SCENARIO)
    with pytest.raises(WorldError, match="another model"):
        build_world(other, datetime(2024, 4, 1), "T-FRAME-L01", tables=world_tables(project))


def test_element_index_gives_the_rows_of_the_property_path_query(b3x2: Path) -> None:
    for directory, scenario in ((b3x2, None), (CASE_STUDY, "storage-outside")):
        model = Project.load(directory, scenario=scenario).model
        new = [tuple(r) for r in model.query(query_text("schedule_element_index"))]  # type: ignore[arg-type]
        old = [tuple(r) for r in model.query(PATH_INDEX)]  # type: ignore[arg-type]
        assert new == old
        assert len(new) == len(set(new)) > 0
        assert any(r[4] is not None for r in new)
