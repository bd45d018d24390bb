"""The schedule as RDF, and the state of every element at a date (named query element_state_at)."""

from __future__ import annotations

from datetime import UTC, datetime
from pathlib import Path

import pytest
from rdflib import RDF, RDFS, XSD, BNode, Graph, Literal, URIRef
from rdflib.plugins.sparql import prepareQuery

from kbplanner.core.errors import QueryError
from kbplanner.core.iris import element_iri, task_iri
from kbplanner.core.resources import queries_dir
from kbplanner.core.vocab import BOT, KBP
from kbplanner.model.schedule import (
    Schedule,
    Task,
    element_state_rows,
    element_states,
    read_csv_schedule,
    schedule_iri,
    schedule_to_graph,
)

BASE = "https://w3id.org/kbplanner/data/test/"
E1, E2, E3, E4 = (element_iri(BASE, f"{c}" * 22) for c in "ABCD")


def make_schedule(reverse: bool = False) -> Schedule:
    """T1 builds E1 and E3 (4-5 Mar), T2 builds E2 after T1 (6-7 Mar), T3 rebuilds E3 (8-9 Mar)."""
    tasks = (
        Task("T1", "Frames level 1", datetime(2024, 3, 4, 8), datetime(2024, 3, 5, 17), (), (E1, E3), True,
             "I-W-F-#1"),
        Task("T2", "Frames level 2", datetime(2024, 3, 6), datetime(2024, 3, 7, 23, 59, 59), ("T1",), (E2,)),
        Task("T3", "Refit", datetime(2024, 3, 8, 8), datetime(2024, 3, 9, 12), ("T1", "T2"), (E3,)),
    )
    return Schedule("plan", "Plan", "/somewhere/plan.csv", tasks[::-1] if reverse else tasks)


def make_graph(store: str = "default") -> Graph:
    """Model (four elements, E4 in no task) plus the schedule graph."""
    g = Graph(store=store)
    for e, gid in ((E1, "A" * 22), (E2, "B" * 22), (E3, "C" * 22), (E4, "D" * 22)):
        g.add((e, RDF.type, KBP.Wall))
        g.add((e, RDF.type, BOT.Element))
        g.add((e, KBP.globalId, Literal(gid)))
        g.add((e, RDFS.label, Literal(f"wall {gid[0]}")))
    # Not building elements: never in the result.
    opening, storey = element_iri(BASE, "O" * 22), element_iri(BASE, "S" * 22)
    g.add((opening, RDF.type, KBP.Opening))
    g.add((opening, RDF.type, BOT.Element))
    g.add((storey, RDF.type, BOT.Storey))
    for node in (opening, storey):
        g.add((node, KBP.globalId, Literal(str(node)[-22:])))
    for t in schedule_to_graph(make_schedule(), BASE):
        g.add(t)
    return g


def test_schedule_graph_has_typed_tasks_with_dates_predecessors_elements_and_robot_use() -> None:
    g = schedule_to_graph(make_schedule(), BASE)
    s = schedule_iri(BASE, "plan")
    t1, t2, t3 = (task_iri(BASE, i) for i in ("T1", "T2", "T3"))
    assert (s, RDF.type, KBP.ConstructionSchedule) in g
    assert set(g.objects(s, KBP.hasTask)) == {t1, t2, t3}
    assert g.value(s, KBP.sourceFile) == Literal("plan.csv")  # file name only: no machine paths
    assert (t1, RDF.type, KBP.ConstructionTask) in g
    assert g.value(t1, KBP.taskId) == Literal("T1")
    assert g.value(t1, RDFS.label) == Literal("Frames level 1")
    assert g.value(t1, KBP.start) == Literal("2024-03-04T08:00:00", datatype=XSD.dateTime)
    assert g.value(t2, KBP.finish) == Literal("2024-03-07T23:59:59", datatype=XSD.dateTime)
    assert g.value(t1, KBP.robotized) == Literal(True, datatype=XSD.boolean)
    assert g.value(t2, KBP.robotized) == Literal(False, datatype=XSD.boolean)
    assert g.value(t1, KBP.taskSpecificationId) == Literal("I-W-F-#1")
    assert g.value(t2, KBP.taskSpecificationId) is None
    assert set(g.objects(t3, KBP.predecessor)) == {t1, t2}
    assert set(g.objects(t1, KBP.buildsElement)) == {E1, E3}


def test_schedule_graph_serialises_to_identical_bytes_whatever_the_task_order() -> None:
    a = schedule_to_graph(make_schedule(), BASE)
    b = schedule_to_graph(make_schedule(reverse=True), BASE)
    assert not any(isinstance(x, BNode) for triple in a for x in triple)
    for fmt in ("turtle", "nt"):
        ta = a.serialize(format=fmt)
        assert ta == schedule_to_graph(make_schedule(), BASE).serialize(format=fmt)
        if fmt == "turtle":
            assert ta == b.serialize(format=fmt)
        else:  # N-Triples follows store order; sorted lines are the same
            assert sorted(ta.splitlines()) == sorted(b.serialize(format=fmt).splitlines())


B, P, N = KBP.Built, KBP.InProgress, KBP.NotStarted


@pytest.mark.parametrize("store", ["default", "Oxigraph"])
@pytest.mark.parametrize("at,expected", [
    (datetime(2024, 3, 1), {E1: N, E2: N, E3: N, E4: B}),         # before: only unscheduled E4 exists
    (datetime(2024, 3, 4, 8), {E1: P, E2: N, E3: N, E4: B}),      # at the start: in progress
    (datetime(2024, 3, 5, 17), {E1: P, E2: N, E3: N, E4: B}),     # at the finish: still in progress
    (datetime(2024, 3, 5, 17, 0, 1), {E1: B, E2: N, E3: N, E4: B}),  # E3: its latest task T3 decides
    (datetime(2024, 3, 7, 12), {E1: B, E2: P, E3: N, E4: B}),
    (datetime(2024, 3, 8, 9), {E1: B, E2: B, E3: P, E4: B}),
    (datetime(2024, 4, 1), {E1: B, E2: B, E3: B, E4: B}),          # after: everything built
])
def test_element_state_at_a_date_is_built_in_progress_or_not_started(
    store: str, at: datetime, expected: dict[URIRef, URIRef]
) -> None:
    assert element_states(make_graph(store), at) == expected


def test_element_state_rows_carry_global_id_and_label_sorted_by_element() -> None:
    rows = element_state_rows(make_graph(), datetime(2024, 3, 4, 12))
    assert [r.element for r in rows] == sorted([E1, E2, E3, E4], key=str)
    r1 = next(r for r in rows if r.element == E1)
    assert (r1.global_id, r1.label, r1.state) == ("A" * 22, "wall A", KBP.InProgress)


def test_element_states_from_a_csv_schedule_use_end_of_day_for_date_only_finish(tmp_path: Path) -> None:
    model = make_graph()
    p = tmp_path / "s.csv"
    p.write_text("task_id,name,start,finish,predecessors,elements,robotized,task_specification\n"
                 f"W,Walls,2024-05-02,2024-05-02,,{'D' * 22},,\n", encoding="utf-8")
    g = model + schedule_to_graph(read_csv_schedule(p, model), BASE)
    assert element_states(g, datetime(2024, 5, 2, 23, 59, 59))[E4] == KBP.InProgress
    assert element_states(g, datetime(2024, 5, 3))[E4] == KBP.Built
    assert element_states(g, datetime(2024, 5, 1, 23, 59, 59))[E4] == KBP.NotStarted


def test_element_states_refuse_a_date_with_time_zone() -> None:
    with pytest.raises(QueryError, match="time zone"):
        element_states(make_graph(), datetime(2024, 3, 4, tzinfo=UTC))


def test_element_state_query_file_has_the_named_query_header_and_projects_the_bound_date() -> None:
    text = (queries_dir() / "element_state_at.rq").read_text(encoding="utf-8")
    head = text.splitlines()[:4]
    assert head == [
        "# name: element_state_at",
        "# description: The state (built, in progress, not started) of every scheduled element at a date.",
        "# param: at xsd:dateTime  the date and time to evaluate",
        "# columns: element globalId label state",
    ]
    query = prepareQuery(text)
    assert [str(v) for v in query.algebra["PV"]] == ["element", "globalId", "label", "state", "at"]
