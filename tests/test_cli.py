"""The console script, through a subprocess: help for every command, exit codes, no tracebacks."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from kbplanner.cli import COMMANDS
from project_factory import make_project

KB = [sys.executable, "-m", "kbplanner.cli"]


def run(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run([*KB, *args], capture_output=True, text=True, cwd=cwd, timeout=300)


@pytest.fixture(scope="module")
def project_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("cliproj")
    make_project(d)
    return d


def test_the_console_script_is_installed_and_answers_version() -> None:
    exe = Path(sys.executable).with_name("kbplanner")
    out = subprocess.run([str(exe), "--version"], capture_output=True, text=True, check=True)
    assert out.stdout.startswith("kbplanner ")


@pytest.mark.parametrize("command", COMMANDS)
def test_every_command_has_help(command: str) -> None:
    out = run(command.replace("_", "-"), "--help")
    assert out.returncode == 0, out.stderr
    assert "usage:" in out.stdout


def test_no_command_prints_help_and_exits_2() -> None:
    out = run()
    assert out.returncode == 2
    assert "usage:" in out.stdout


def test_info_summarises_the_project(project_dir: Path) -> None:
    out = run("info", str(project_dir))
    assert out.returncode == 0, out.stderr
    assert "Wall" in out.stdout and "2 interior, 8 exterior" in out.stdout
    assert "4 tasks" in out.stdout


def test_query_list_describes_parameters() -> None:
    out = run("query", "--list")
    assert out.returncode == 0
    assert "doors_and_widths" in out.stdout and "--bind storeyLabel=" in out.stdout


def test_query_with_binding_prints_csv(project_dir: Path) -> None:
    out = run("query", str(project_dir), "doors_and_widths", "--bind", "storeyLabel=Level 1",
              "--format", "csv")
    assert out.returncode == 0, out.stderr
    lines = out.stdout.strip().splitlines()
    assert lines[0].startswith("door,globalId")
    assert len(lines) == 3  # the front door and the partition door of the ground floor
    assert all(",Level 1," in line for line in lines[1:])


def test_query_with_own_sparql_file(project_dir: Path, tmp_path: Path) -> None:
    q = tmp_path / "walls.rq"
    q.write_text("PREFIX kbp: <https://w3id.org/kbplanner/ontology#>\n"
                 "SELECT ?w WHERE { ?w a kbp:Wall ; kbp:isExternal ?ext }")
    out = run("query", str(project_dir), "--sparql", str(q), "--format", "json")
    assert out.returncode == 0, out.stderr
    assert out.stdout.count('"w":') == 10


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (("info", "/nonexistent/project"), "project directory not found"),
        (("query", "{p}", "nope"), "no named query 'nope'"),
        (("query", "{p}", "storeys", "--bind", "x"), "is not VAR=VALUE"),
        (("query", "{p}", "--sparql", "/nonexistent.rq"), "query file not found"),
        (("info", "{p}", "--scenario", "missing"), "unknown scenario"),
        (("run", "/nonexistent/project", "--out", "/tmp/kbp-none"), "project directory not found"),
        (("run", "{p}", "--out", "/tmp/kbp-none", "--scenario", "missing"), "unknown scenario"),
    ],
)
def test_bad_input_exits_2_with_one_message_and_no_traceback(project_dir: Path, args: tuple[str, ...],
                                                              needle: str) -> None:
    out = run(*(a.replace("{p}", str(project_dir)) for a in args))
    assert out.returncode == 2
    assert needle in out.stderr
    assert "Traceback" not in out.stderr


def test_a_sparql_syntax_error_exits_2(project_dir: Path, tmp_path: Path) -> None:
    q = tmp_path / "bad.rq"
    q.write_text("SELECT ?x WHERE { ?x ?y }")
    out = run("query", str(project_dir), "--sparql", str(q))
    assert out.returncode == 2
    assert "bad.rq" in out.stderr and "Traceback" not in out.stderr
