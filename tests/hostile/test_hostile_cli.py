"""The hostile suite: every command against bad paths, non-finite and out-of-range numbers, bad files.

Each case runs in a fresh copy of a tiny workspace (``conftest.py``) and must exit with its code (2: bad
input; 1: a real negative result), print one error message and no traceback, leave no ``.partial``
folder, and change no file outside the fresh output folder. Part B's cases (numbers in knowledge-base
and site files, site locations) go into ``FILE_CASES``.
"""

from __future__ import annotations

import json
import os
import stat
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest

from hostile.harness import FRESH, Workspace, one_message

DATE = ["--date", "2022-04-01"]
# Every command that writes a folder, with the arguments that it needs besides --out.
WRITERS: dict[str, list[str]] = {
    "world": ["world", "proj", *DATE],
    "plan": ["plan", "proj"],
    "simulate": ["simulate", "proj"],
    "run": ["run", "proj"],
    "compare": ["compare", "proj", "--scenarios", "a"],
    "sweep": ["sweep", "proj", "--vary", "seed=1"],
    "report": ["report", "userdir"],
    "generate-building": ["generate-building", "--storeys", "1", "--units-per-storey", "1"],
}
# --out values that the output rule refuses, with a word of the message.
BAD_OUTS: dict[str, tuple[str, str, str]] = {  # id: (value, cwd, needle)
    "project-folder": ("proj", ".", "project folder"),
    "current-folder": (".", "proj", "current folder"),  # '.' inside a project
    "current-folder-plain": (".", "userdir", "current folder"),
    "parent-of-current": ("..", "userdir", "current folder"),
    "existing-file": ("user.txt", ".", "existing file"),
    "below-a-file": ("user.txt/x", ".", "below a file"),
    "users-folder": ("userdir", ".", "did not write"),
}


def _paths() -> list[object]:
    return [pytest.param(cmd, bad, id=f"{cmd}-{bad}") for cmd in WRITERS for bad in BAD_OUTS]


@pytest.mark.parametrize("command, bad", _paths())
def test_every_writer_refuses_every_bad_out(workspace: Workspace, command: str, bad: str) -> None:
    value, cwd, needle = BAD_OUTS[bad]
    argv = list(WRITERS[command])
    if cwd != ".":  # the project (and userdir) seen from the case's folder
        argv = ["../proj" if a == "proj" else "../userdir" if a == "userdir" else a for a in argv]
    code, err = workspace.run([*argv, "--out", value], cwd=cwd)
    assert code == 2
    assert needle in one_message(err) or (bad == "users-folder" and command == "report")


@pytest.mark.parametrize("command", [c for c in WRITERS if c != "report"])
def test_force_never_makes_a_project_folder_or_a_file_an_output(workspace: Workspace, command: str) -> None:
    for value in ("proj", "user.txt"):
        code, err = workspace.run([*WRITERS[command], "--out", value, "--force"])
        assert code == 2 and ("project folder" in err or "existing file" in err)


@dataclass(frozen=True)
class Case:
    argv: tuple[str, ...]
    code: int
    needle: str
    cwd: str = "."
    setup: Callable[[Path], None] | None = None


def _case(*argv: str, code: int = 2, needle: str = "", cwd: str = ".",
          setup: Callable[[Path], None] | None = None) -> Case:
    return Case(tuple(argv), code, needle, cwd, setup)


OUT = ["--out", FRESH]
# Numbers on the command line: finite and in range, or exit 2 before any work.
FLAG_CASES: dict[str, Case] = {
    "run-max-elements-0": _case("run", "proj", "--max-elements", "0", *OUT, needle="out of range"),
    "run-max-elements-neg": _case("run", "proj", "--max-elements", "-1", *OUT, needle="out of range"),
    "run-workers-0": _case("run", "proj", "--workers", "0", *OUT, needle="out of range"),
    "run-seed-neg": _case("run", "proj", "--seed", "-1", *OUT, needle="out of range"),
    "run-seed-huge": _case("run", "proj", "--seed", str(2**40), *OUT, needle="out of range"),
    "run-seed-nan": _case("run", "proj", "--seed", "nan", *OUT, needle="not a whole number"),
    "simulate-seed-float": _case("simulate", "proj", "--seed", "1.5", *OUT, needle="not a whole number"),
    "compare-seed-neg": _case("compare", "proj", "--scenarios", "a", "--seed", "-3", *OUT,
                              needle="out of range"),
    "compare-threshold-nan": _case("compare", "proj", "--scenarios", "a", "--threshold", "nan", *OUT,
                                   needle="not a finite number"),
    "report-threshold-neg": _case("report", "userdir", "--threshold", "-1", needle="out of range"),
    "report-threshold-inf": _case("report", "userdir", "--threshold", "inf", needle="not a finite"),
    "sweep-workers-0": _case("sweep", "proj", "--vary", "seed=1", "--workers", "0", *OUT,
                             needle="out of range"),
    "sweep-max-elements-0": _case("sweep", "proj", "--vary", "seed=1", "--max-elements", "0", *OUT,
                                  needle="out of range"),
    "sweep-threshold-0": _case("sweep", "proj", "--vary", "seed=1", "--threshold", "0", *OUT,
                               needle="out of range"),
    "world-resolution-nan": _case("world", "proj", *DATE, "--resolution", "nan", *OUT,
                                  needle="not a finite number"),
    "world-resolution-0": _case("world", "proj", *DATE, "--resolution", "0", *OUT, needle="out of range"),
    "world-robot-height-inf": _case("world", "proj", *DATE, "--robot-height", "inf", *OUT,
                                    needle="not a finite number"),
    "world-robot-height-neg": _case("world", "proj", *DATE, "--robot-height", "-1", *OUT,
                                    needle="out of range"),
    "world-bad-date": _case("world", "proj", "--date", "2022-13-45", *OUT, needle="date"),
    "plan-bad-date": _case("plan", "proj", "--date", "yesterday", needle="date"),
    "import-processes-0": _case("import-ifc", "proj/model.ifc", "--processes", "0", *OUT,
                                needle="out of range"),
    "generate-storeys-0": _case("generate-building", "--storeys", "0", "--units-per-storey", "1", *OUT,
                                needle="--storeys"),
    "generate-units-huge": _case("generate-building", "--storeys", "1", "--units-per-storey", "999", *OUT,
                                 needle="--units-per-storey"),
    "generate-seed-neg": _case("generate-building", "--storeys", "1", "--units-per-storey", "1", "--seed",
                               "-1", *OUT, needle="out of range"),
    "query-bind-bad-date": _case("query", "proj", "element_state_at", "--bind", "at=2022-13-45",
                                 needle="is not a valid xsd:dateTime"),
    "query-bind-unknown": _case("query", "proj", "element_state_at", "--bind", "at=2022-01-01",
                                "--bind", "nope=nan", needle="no parameter"),
}

# Single-file outputs and other paths.
PATH_CASES: dict[str, Case] = {
    "validate-report-folder": _case("validate", "proj", "--report", "userdir", needle="is a folder"),
    "validate-report-users-file": _case("validate", "proj", "--report", "report.ttl", needle="did not write"),
    "validate-report-below-file": _case("validate", "proj", "--report", "user.txt/r.ttl",
                                        needle="below a file"),
    "validate-report-unwritable": _case("validate", "proj", "--well-formedness-only", "--report",
                                        "/sys/kbplanner-hostile.ttl", needle="cannot write"),
    "requirements-template-users-file": _case("requirements", "proj", "--template", "user.txt",
                                              needle="did not write"),
    "requirements-template-folder": _case("requirements", "proj", "--template", "userdir",
                                          needle="is a folder"),
    "world-unwritable": _case("world", "proj", *DATE, "--out", "/sys/kbplanner-hostile",
                              needle="cannot write"),
    "import-into-users-file": _case("import-ifc", "proj/model.ifc", "--out", "user.txt", needle="file"),
    "import-unwritable": _case("import-ifc", "proj/model.ifc", "--out", "/sys/kbplanner-hostile",
                               needle="cannot write"),
    "import-below-a-file": _case("import-ifc", "proj/model.ifc", "--out", "user.txt/p",
                                 needle="below a file"),
    "import-over-users-model": _case("import-ifc", "proj/model.ifc", "--out", "userdir",
                                     needle="not written by an import",
                                     setup=lambda r: (r / "userdir" / "model.ttl").write_text("# mine\n")),
    "import-over-users-meshes": _case("import-ifc", "proj/model.ifc", "--out", "userdir",
                                      needle="meshes/ holds files",
                                      setup=lambda r: ((r / "userdir" / "meshes").mkdir(),
                                                       (r / "userdir" / "meshes" / "a.txt").write_text("x"))),
    "report-not-a-run": _case("report", "userdir", *OUT, needle="userdir"),
    "missing-project": _case("plan", "nowhere", needle="nowhere"),
    "query-bind-iri-gt": _case("query", "proj", "plan_box", "--bind", "box=https://a/b>c",
                               needle="not an absolute IRI"),
    "query-bind-iri-gt-oxigraph": _case("query", "proj", "plan_box", "--bind", "box=https://a/b>c",
                                        "--store", "oxigraph", needle="not an absolute IRI"),
    "query-sparql-bind-iri-gt": _case("query", "proj", "--sparql", "q.rq", "--bind", "s=<https://a/b>c>",
                                      needle="not an absolute IRI",
                                      setup=lambda r: (r / "q.rq").write_text("SELECT * { ?s ?p ?o }")),
}


def _bad_toml(root: Path) -> None:
    (root / "proj" / "project.toml").write_text("[project\nname = 1\n")


def _bad_turtle(root: Path) -> None:
    with open(root / "proj" / "site.ttl", "a") as fh:
        fh.write("\nsite:x kbp:minX 1.0 site:y .\n")


def _bad_csv(root: Path) -> None:
    with open(root / "proj" / "schedule.csv", "a") as fh:
        fh.write("T9,Broken,2022-02-30,2022-01-01,,class=IfcWall,false,\n")


def _bad_ifc(root: Path) -> None:
    (root / "proj" / "model.ifc").write_text("these are meeting notes, not a building\n")


def _site_number(prop: str, value: str) -> Callable[[Path], None]:
    """Append ``site:hostile <prop> <value>`` to the project's site Turtle."""
    def setup(root: Path) -> None:
        with open(root / "proj" / "site.ttl", "a") as fh:
            fh.write(f'\nsite:hostile {prop} {value} .\n')
    return setup


_XSD_DOUBLE = "^^<http://www.w3.org/2001/XMLSchema#double>"
# The numeric rule for numbers in files: every command that reads the file stops with exit 2.
NUMBER_CASES: dict[str, Case] = {
    f"{command}-{prop.split(':')[1]}-{label}": _case(
        command, "proj", *(OUT if command in ("plan", "simulate", "run") else ()), needle=prop,
        setup=_site_number(prop, value))
    for command in ("validate", "plan", "simulate", "run", "info")
    for prop, label, value in (
        ("kbp:maxSpeed", "nan", f'"NaN"{_XSD_DOUBLE}'),
        ("kbp:maxSpeed", "inf", f'"INF"{_XSD_DOUBLE}'),
        ("kbp:maxSpeed", "negative", "-1.0"),
        ("kbp:safetyStopDistance", "inf", f'"INF"{_XSD_DOUBLE}'),
        ("kbp:walkingSpeed", "zero", "0.0"),
        ("kbp:dwellTime", "negative", "-5.0"),
        ("kbp:sizeX", "zero", "0.0"),
        ("kbp:x", "inf", f'"-INF"{_XSD_DOUBLE}'),
    )
}

# Malformed input files.
FILE_CASES: dict[str, Case] = {
    **NUMBER_CASES,
    "bad-toml": _case("validate", "proj", needle="project.toml", setup=_bad_toml),
    "bad-turtle": _case("validate", "proj", needle="site.ttl", setup=_bad_turtle),
    "bad-csv": _case("plan", "proj", needle="schedule.csv", setup=_bad_csv),
    "bad-ifc": _case("info", "proj", needle="model.ifc", setup=_bad_ifc),
}

ALL_CASES = {**FLAG_CASES, **PATH_CASES, **FILE_CASES}


@pytest.mark.parametrize("name", list(ALL_CASES))
def test_hostile_case(workspace: Workspace, name: str) -> None:
    case = ALL_CASES[name]
    if case.setup is not None:
        case.setup(workspace.root)
    code, err = workspace.run(list(case.argv), cwd=case.cwd)
    assert code == case.code, err
    assert case.needle in one_message(err), err
    assert not (workspace.root / FRESH).exists()


def test_the_console_script_prints_one_message_without_a_traceback(workspace: Workspace) -> None:
    """Through a real process: what a user sees on stderr (a few cases; the rest run in-process)."""
    for argv in (["world", "proj", *DATE, "--out", "proj"], ["run", "proj", "--max-elements", "0", *OUT],
                 ["plan", "proj", "--out", "user.txt/x"]):
        out = subprocess.run([sys.executable, "-m", "kbplanner", *argv], capture_output=True, text=True,
                             cwd=workspace.root, timeout=120)
        assert out.returncode == 2 and "Traceback" not in out.stderr
        one_message(out.stderr)


@pytest.mark.parametrize("command", ["world", "plan", "generate-building"])
def test_an_immutable_output_folder_is_refused_before_any_work(workspace: Workspace, command: str) -> None:
    """``chattr +i`` (root on ext4 and the like): no file can be created in the folder or below it."""
    folder = workspace.root / "frozen"
    folder.mkdir()
    if subprocess.run(["chattr", "+i", str(folder)], capture_output=True).returncode != 0:
        pytest.skip("chattr +i is not available here")
    try:
        for out in ("frozen", "frozen/x"):
            code, err = workspace.run([*WRITERS[command], "--out", out])
            assert code == 2 and "cannot write" in one_message(err)
    finally:
        subprocess.run(["chattr", "-i", str(folder)], check=True)


# Every command that reads a project, with the arguments it needs after the project.
READERS: dict[str, tuple[list[str], list[str]]] = {
    "info": (["info"], []),
    "robots": (["robots"], []),
    "requirements": (["requirements"], []),
    "validate": (["validate"], []),
    "query": (["query"], ["storeys"]),
    "world": (["world"], [*DATE, *OUT]),
    "plan": (["plan"], []),
    "simulate": (["simulate"], OUT),
    "run": (["run"], OUT),
    "compare": (["compare"], ["--scenarios", "a", *OUT]),
    "sweep": (["sweep"], ["--vary", "seed=1", *OUT]),
}
BAD_PROJECTS = {"a-file": ("user.txt", "project directory not found"),
                "no-manifest": ("userdir", "no project.toml"),
                "missing": ("nowhere", "project directory not found")}


@pytest.mark.parametrize("command", list(READERS))
@pytest.mark.parametrize("bad", list(BAD_PROJECTS))
def test_every_reader_refuses_a_path_that_is_not_a_project(workspace: Workspace, command: str,
                                                           bad: str) -> None:
    head, tail = READERS[command]
    path, needle = BAD_PROJECTS[bad]
    code, err = workspace.run([*head, path, *tail])
    assert code == 2 and needle in one_message(err) and path in one_message(err)
    assert not (workspace.root / FRESH).exists()


def _strict(text: str) -> object:
    def refuse(constant: str) -> object:
        raise AssertionError(f"{constant} in JSON")

    return json.loads(text, parse_constant=refuse)


@pytest.mark.parametrize("argv", [["world", "proj", *DATE]], ids=["world"])
def test_what_a_command_writes_is_strict_json_with_the_umask_mode(workspace: Workspace,
                                                                 argv: list[str]) -> None:
    old = os.umask(0o027)
    try:
        code, _err = workspace.run([*argv, *OUT])
    finally:
        os.umask(old)
    assert code in (0, 1)
    files = [p for p in (workspace.root / FRESH).rglob("*") if p.is_file()]
    assert any(p.suffix == ".json" for p in files)
    for p in files:
        if p.suffix == ".json" or p.name == ".kbplanner-run":
            _strict(p.read_text())
        assert stat.S_IMODE(p.stat().st_mode) == 0o640, p
