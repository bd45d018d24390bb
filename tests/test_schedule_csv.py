"""The CSV schedule reader: format, date conventions, selectors, and every documented error."""

from __future__ import annotations

from datetime import datetime
from pathlib import Path

import ifcopenshell.guid
import pytest
from rdflib import RDF, RDFS, XSD, Graph, Literal, URIRef

from kbplanner.core.errors import InputFileError, KbplannerError, ScheduleCycleError, ScheduleError
from kbplanner.core.iris import element_iri
from kbplanner.core.vocab import BOT, KBP
from kbplanner.model.schedule import read_csv_schedule
from kbplanner.model.schedule_csv import COLUMNS

BASE = "https://w3id.org/kbplanner/data/test/"
HEADER = ",".join(COLUMNS)


def gid(n: int) -> str:
    """A fixed, valid 22-character IFC GlobalId."""
    return str(ifcopenshell.guid.compress(f"{n:032x}"))


# name, IFC class, kbp type, storey, isExternal
ELEMENTS = {
    1: ("Basic Wall:Exterior 200", "IfcWallStandardCase", KBP.Wall, "Level 1", True),
    2: ("Interior Frame 1", "IfcWallStandardCase", KBP.Wall, "Level 1", False),
    3: ("Interior Frame 2", "IfcWall", KBP.Wall, "Level 2", False),
    4: ("Door 1", "IfcDoor", KBP.Door, "Level 1", None),
    5: ("Stud 1", "IfcMember", KBP.Member, "Level 2", None),
    6: ("Window 1", "IfcWindow", KBP.Window, "Level 1", None),
}


def el(n: int) -> URIRef:
    return element_iri(BASE, gid(n))


def build_model(store: str = "default") -> Graph:
    """A small model graph in the shape the IFC import writes."""
    g = Graph(store=store)
    storeys = {label: URIRef(f"{BASE}storey/{label.replace(' ', '-')}") for label in ("Level 1", "Level 2")}
    for label, s in storeys.items():
        g.add((s, RDF.type, BOT.Storey))
        g.add((s, RDFS.label, Literal(label)))
    for n, (name, cls, typ, storey, ext) in ELEMENTS.items():
        e = el(n)
        g.add((e, RDF.type, typ))
        g.add((e, RDF.type, BOT.Element))
        g.add((e, KBP.globalId, Literal(gid(n))))
        g.add((e, KBP.ifcClass, Literal(cls)))
        g.add((e, RDFS.label, Literal(name)))
        g.add((storeys[storey], BOT.containsElement, e))
        if ext is not None:
            g.add((e, KBP.isExternal, Literal(ext, datatype=XSD.boolean)))
    # Not building elements: a space and an opening on Level 1 with GlobalIds and matching names.
    space, opening = el(20), el(21)
    g.add((space, RDF.type, BOT.Space))
    g.add((storeys["Level 1"], BOT.hasSpace, space))
    g.add((opening, RDF.type, KBP.Opening))
    g.add((opening, RDF.type, BOT.Element))
    for node, n, cls, name in ((space, 20, "IfcSpace", "Interior Frame room"),
                               (opening, 21, "IfcOpeningElement", "Interior Frame opening")):
        g.add((node, KBP.globalId, Literal(gid(n))))
        g.add((node, KBP.ifcClass, Literal(cls)))
        g.add((node, RDFS.label, Literal(name)))
        g.add((storeys["Level 1"], BOT.containsElement, node))
    return g


def write(tmp_path: Path, *rows: str, header: str = HEADER, name: str = "schedule.csv") -> Path:
    p = tmp_path / name
    p.write_text("\n".join([header, *rows]) + "\n", encoding="utf-8")
    return p


def test_csv_schedule_is_read_with_dates_predecessors_elements_and_robot_use(tmp_path: Path) -> None:
    p = write(
        tmp_path,
        f"T1,Exterior walls,2024-03-04T08:00,2024-03-05T17:00,,{gid(1)},false,",
        f'T2,"Interior frames, level 1",2024-03-06,2024-03-07,T1,{gid(2)}|{gid(4)},yes,I-W-F-#1',
        f"T3,Level 2,2024-03-08T07:30:15,2024-03-08T16:00:00,T1;T2,{gid(3)},0,",
    )
    s = read_csv_schedule(p, build_model())
    assert [t.task_id for t in s.tasks] == ["T1", "T2", "T3"]
    t1, t2, t3 = s.tasks
    assert t1.name == "Exterior walls"
    assert (t1.start, t1.finish) == (datetime(2024, 3, 4, 8), datetime(2024, 3, 5, 17))
    assert t2.name == "Interior frames, level 1"
    assert t2.predecessors == ("T1",)
    assert t3.predecessors == ("T1", "T2")
    assert t2.element_iris == (el(2), el(4))
    assert (t2.robotized, t2.task_specification_id) == (True, "I-W-F-#1")
    assert (t1.robotized, t1.task_specification_id) == (False, None)
    assert t3.start == datetime(2024, 3, 8, 7, 30, 15)
    assert s.schedule_id == "schedule" and s.source == str(p)
    assert s.robotized_tasks() == (t2,)
    assert s.start == datetime(2024, 3, 4, 8) and s.finish == datetime(2024, 3, 8, 16)


def test_date_only_start_is_midnight_and_date_only_finish_is_end_of_day(tmp_path: Path) -> None:
    p = write(tmp_path, f"T1,Walls,2024-03-04,2024-03-04,,{gid(1)},,")
    (t,) = read_csv_schedule(p, build_model()).tasks
    assert t.start == datetime(2024, 3, 4, 0, 0, 0)
    assert t.finish == datetime(2024, 3, 4, 23, 59, 59)


def test_date_only_finish_on_the_start_day_is_not_before_a_timed_start(tmp_path: Path) -> None:
    p = write(tmp_path, f"T1,Walls,2024-03-04T15:00,2024-03-04,,{gid(1)},,")
    (t,) = read_csv_schedule(p, build_model()).tasks
    assert (t.start, t.finish) == (datetime(2024, 3, 4, 15), datetime(2024, 3, 4, 23, 59, 59))


def test_predecessors_may_be_separated_by_spaces_or_semicolons_and_follow_later_rows(tmp_path: Path) -> None:
    p = write(
        tmp_path,
        "T9,Last,2024-03-10,2024-03-10,T1 T2; T3,,,",
        "T1,A,2024-03-04,2024-03-04,,,,",
        "T2,B,2024-03-05,2024-03-05,,,,",
        "T3,C,2024-03-06,2024-03-06,T1;;T1,,,",
    )
    s = read_csv_schedule(p, build_model())
    assert s.task("T9").predecessors == ("T1", "T2", "T3")
    assert s.task("T3").predecessors == ("T1",)


def test_columns_may_come_in_any_order_with_a_bom_and_extra_columns(tmp_path: Path) -> None:
    p = tmp_path / "s.csv"
    header = "elements,task_id,finish,start,name,predecessors,robotized,task_specification,notes"
    p.write_text("\ufeff" + header + f"\n{gid(5)},T1,2024-03-05,2024-03-04,Studs,,true,I-W-F-#1,hello\n",
                 encoding="utf-8")
    (t,) = read_csv_schedule(p, build_model()).tasks
    assert (t.task_id, t.name, t.element_iris, t.robotized) == ("T1", "Studs", (el(5),), True)


@pytest.mark.parametrize("word,expected", [
    ("true", True), ("TRUE", True), ("yes", True), ("1", True),
    ("false", False), ("no", False), ("0", False), ("", False),
])
def test_robotized_accepts_documented_spellings(tmp_path: Path, word: str, expected: bool) -> None:
    p = write(tmp_path, f"T1,Walls,2024-03-04,2024-03-04,,,{word},I-W-F-#1")
    assert read_csv_schedule(p, build_model()).tasks[0].robotized is expected


@pytest.mark.parametrize("entry,expected", [
    ("class=IfcWall", [2, 1, 3]),  # IfcWall matches IfcWallStandardCase too; order: by GlobalId
    ("class=ifcwallstandardcase", [2, 1]),
    ("class=IfcWindow", [6]),
    ("storey=Level 2", [5, 3]),
    ("name=Interior Frame *", [2, 3]),
    ("name=interior frame *", None),  # glob is case-sensitive
    ("external=true", [1]),
    ("class=IfcWall;external=false", [2, 3]),
    ("class=IfcWall; storey=Level 1; external=no", [2]),
    ("storey=Level 1;name=D*", [4]),
])
def test_selectors_match_class_prefix_storey_name_glob_and_external(
    tmp_path: Path, entry: str, expected: list[int] | None
) -> None:
    p = write(tmp_path, f"T1,Walls,2024-03-04,2024-03-04,,{entry},,")
    if expected is None:
        with pytest.raises(ScheduleError, match="matches no element"):
            read_csv_schedule(p, build_model())
        return
    got = read_csv_schedule(p, build_model()).tasks[0].element_iris
    assert set(got) == {el(n) for n in expected}
    assert list(got) == sorted(got, key=lambda e: next(gid(n) for n in ELEMENTS if el(n) == e))


@pytest.mark.parametrize("entry", ["class=IfcSpace", "class=IfcOpening", "name=*room", "name=*opening"])
def test_selectors_never_match_spaces_storeys_or_openings(tmp_path: Path, entry: str) -> None:
    p = write(tmp_path, f"T1,Walls,2024-03-04,2024-03-04,,{entry},,")
    with pytest.raises(ScheduleError, match="matches no element"):
        read_csv_schedule(p, build_model())


def test_element_entries_are_united_in_order_without_duplicates(tmp_path: Path) -> None:
    entries = f"{gid(4)}|class=IfcWall;storey=Level 1| {gid(1)} |"
    p = write(tmp_path, f"T1,Mixed,2024-03-04,2024-03-04,,{entries},,")
    got = read_csv_schedule(p, build_model()).tasks[0].element_iris
    assert got[0] == el(4)
    assert set(got) == {el(4), el(1), el(2)} and len(got) == 3


def test_selectors_resolve_against_an_oxigraph_backed_model(tmp_path: Path) -> None:
    p = write(tmp_path, f"T1,Walls,2024-03-04,2024-03-04,,class=IfcWall;storey=Level 1|{gid(5)},,")
    got = read_csv_schedule(p, build_model(store="Oxigraph")).tasks[0].element_iris
    assert set(got) == {el(1), el(2), el(5)}


GOOD = "T1,Walls,2024-03-04,2024-03-05,,,,"

# rows after the header, line of the error, column named, words the message must contain
ERRORS = [
    ("bad date", [GOOD, "T2,X,2024-02-30,2024-03-05,,,,"], 3, "start", "not a valid date"),
    ("bad date format", ["T1,X,04.03.2024,2024-03-05,,,,"], 2, "start", "not a valid date"),
    ("time zone", ["T1,X,2024-03-04T08:00+01:00,2024-03-05,,,,"], 2, "start", "has a time zone"),
    ("empty finish", ["T1,X,2024-03-04,,,,,"], 2, "finish", "finish is empty"),
    ("finish before start", [GOOD, "T2,X,2024-03-05T10:00,2024-03-05T09:00,,,,"], 3, "finish",
     "before start"),
    ("unknown predecessor", [GOOD, "T2,X,2024-03-06,2024-03-06,T1 T7,,,"], 3, "predecessors", "'T7'"),
    ("unknown GlobalId", [GOOD, f"T2,X,2024-03-06,2024-03-06,,{gid(99)},,"], 3, "elements",
     "not a building element"),
    ("GlobalId of a space", [GOOD, f"T2,X,2024-03-06,2024-03-06,,{gid(20)},,"], 3, "elements",
     "not a building element"),
    ("not a GlobalId", ["T1,X,2024-03-06,2024-03-06,,wall-1,,"], 2, "elements", "neither"),
    ("duplicate task id", [GOOD, "T2,X,2024-03-06,2024-03-06,,,,", "T1,Y,2024-03-07,2024-03-07,,,,"], 4,
     "task_id", "already used on line 2"),
    ("empty task id", [",X,2024-03-06,2024-03-06,,,,"], 2, "task_id", "empty"),
    ("task id with space", ["T 1,X,2024-03-06,2024-03-06,,,,"], 2, "task_id", "space"),
    ("empty selector match", [GOOD, "T2,X,2024-03-06,2024-03-06,,class=IfcSlab,,"], 3, "elements",
     "class=IfcSlab"),
    ("unknown storey", ["T1,X,2024-03-06,2024-03-06,,storey=Level 9,,"], 2, "elements",
     "Level 1, Level 2"),
    ("unknown selector key", ["T1,X,2024-03-06,2024-03-06,,colour=red,,"], 2, "elements", "key 'colour'"),
    ("bad external", ["T1,X,2024-03-06,2024-03-06,,external=maybe,,"], 2, "elements", "maybe"),
    ("robotized without specification", ["T1,X,2024-03-06,2024-03-06,,,true,"], 2, "task_specification",
     "needs a task specification"),
    ("bad robotized", ["T1,X,2024-03-06,2024-03-06,,,perhaps,"], 2, "robotized", "perhaps"),
]


@pytest.mark.parametrize("rows,line,column,words", [e[1:] for e in ERRORS], ids=[e[0] for e in ERRORS])
def test_bad_rows_raise_schedule_error_naming_file_row_column_and_fix(
    tmp_path: Path, rows: list[str], line: int, column: str, words: str
) -> None:
    p = write(tmp_path, *rows, name="my_plan.csv")
    with pytest.raises(ScheduleError) as info:
        read_csv_schedule(p, build_model())
    msg = str(info.value)
    assert "my_plan.csv" in msg
    assert f":{line}:" in msg and f"row {line}" in msg
    assert f"column '{column}'" in msg
    assert words in msg
    assert "\n  fix: " in msg and info.value.fix
    assert info.value.line == line


def test_missing_columns_are_named_with_the_fix(tmp_path: Path) -> None:
    p = write(tmp_path, "T1,X,2024-03-04,2024-03-05", header="task_id,name,start,finish", name="short.csv")
    with pytest.raises(ScheduleError) as info:
        read_csv_schedule(p, build_model())
    msg = str(info.value)
    assert "short.csv:1:" in msg
    assert "predecessors, elements, robotized, task_specification" in msg
    assert "fix:" in msg and HEADER in msg


def test_a_row_with_too_many_fields_asks_for_quotes(tmp_path: Path) -> None:
    p = write(tmp_path, GOOD, "T2,Walls, level 1,2024-03-04,2024-03-05,,,,")
    with pytest.raises(ScheduleError, match=r"schedule\.csv:3: row 3: 9 fields.*\n  fix: quote"):
        read_csv_schedule(p, build_model())


def test_empty_and_non_utf8_and_missing_files_raise_input_errors(tmp_path: Path) -> None:
    empty = tmp_path / "empty.csv"
    empty.write_text("\n\n", encoding="utf-8")
    with pytest.raises(ScheduleError, match=r"empty\.csv: the file is empty"):
        read_csv_schedule(empty, build_model())
    latin = tmp_path / "latin.csv"
    latin.write_bytes((HEADER + "\nT1,Mauer für Büro,2024-03-04,2024-03-05,,,,\n").encode("latin-1"))
    with pytest.raises(ScheduleError, match=r"latin\.csv: not UTF-8"):
        read_csv_schedule(latin, build_model())
    with pytest.raises(InputFileError, match=r"nowhere\.csv: schedule file not found"):
        read_csv_schedule(tmp_path / "nowhere.csv", build_model())


def test_predecessor_cycle_raises_cycle_error_carrying_the_cycle_in_order(tmp_path: Path) -> None:
    p = write(
        tmp_path,
        "T0,Start,2024-03-01,2024-03-01,,,,",
        "T2,B,2024-03-05,2024-03-05,T1,,,",
        "T3,C,2024-03-06,2024-03-06,T2,,,",
        "T1,A,2024-03-04,2024-03-04,T0 T3,,,",
    )
    with pytest.raises(ScheduleCycleError) as info:
        read_csv_schedule(p, build_model())
    assert info.value.cycle == ["T1", "T2", "T3"]
    assert "schedule.csv" in str(info.value)
    assert "T1 -> T2 -> T3 -> T1" in str(info.value)
    assert "fix:" in str(info.value)


def test_a_task_that_waits_for_itself_is_a_cycle_of_one(tmp_path: Path) -> None:
    p = write(tmp_path, "T1,A,2024-03-04,2024-03-04,T1,,,")
    with pytest.raises(ScheduleCycleError) as info:
        read_csv_schedule(p, build_model())
    assert info.value.cycle == ["T1"]


def test_schedule_errors_are_kbplanner_errors_so_the_cli_prints_them_plainly(tmp_path: Path) -> None:
    p = write(tmp_path, "T1,A,2024-03-04,yesterday,,,,")
    with pytest.raises(KbplannerError):
        read_csv_schedule(p, build_model())


def test_the_example_in_docs_schedule_md_reads_as_documented(tmp_path: Path) -> None:
    doc = (Path(__file__).resolve().parents[1] / "docs" / "schedule.md").read_text(encoding="utf-8")
    example = doc.split("```csv\n", 1)[1].split("```", 1)[0]
    p = tmp_path / "example.csv"
    p.write_text(example, encoding="utf-8")
    model = build_model()
    documented = URIRef(BASE + "element/documented")
    model.add((documented, RDF.type, BOT.Element))
    model.add((documented, KBP.globalId, Literal("2O2Fr$t4X7Zf8NOew3FLOH")))
    s = read_csv_schedule(p, model)
    assert [t.task_id for t in s.tasks] == ["T1", "T2", "T3"]
    assert set(s.task("T1").element_iris) == {el(1)}
    assert s.task("T2").element_iris == (el(2),) and s.task("T2").task_specification_id == "I-W-F-#1"
    assert s.task("T2").finish == datetime(2024, 3, 8, 16, 30)
    assert s.task("T3").element_iris == (el(4), documented) and s.task("T3").predecessors == ("T1", "T2")
    assert s.task("T1").finish == datetime(2024, 3, 6, 23, 59, 59)
