"""The output rule (core.output_dirs), atomic files with the umask's mode, and strict JSON."""

from __future__ import annotations

import json
import os
import stat
from pathlib import Path

import pytest

from kbplanner.core.errors import KbplannerError
from kbplanner.core.output_dirs import (
    MARKER,
    OutputError,
    check_output_dir,
    check_output_file,
    output_options,
    read_marker,
    run_directory,
)
from kbplanner.core.outputs import atomic_write_text, json_text, write_json


def _write(stage: Path, files: dict[str, str]) -> None:
    for rel, text in files.items():
        (stage / rel).parent.mkdir(parents=True, exist_ok=True)
        (stage / rel).write_text(text)


def test_a_new_folder_gets_the_files_and_a_marker_listing_them(tmp_path: Path) -> None:
    out = tmp_path / "run"
    with output_options(command="kbplanner test"), run_directory(out) as stage:
        _write(stage, {"a.json": "1", "sub/b.txt": "2"})
    assert read_marker(out) == {"a.json", "sub/b.txt"}
    marker = json.loads((out / MARKER).read_text())
    assert marker["command"] == "kbplanner test" and marker["written_by"] == "kbplanner"
    assert not (tmp_path / "run.partial").exists()


def test_a_second_run_replaces_its_own_files_and_keeps_the_users(tmp_path: Path) -> None:
    out = tmp_path / "run"
    with run_directory(out) as stage:
        _write(stage, {"a.json": "1", "old/gone.txt": "x"})
    (out / "notes.txt").write_text("mine")
    (out / "mine").mkdir()
    with run_directory(out) as stage:
        _write(stage, {"a.json": "2"})
    assert (out / "a.json").read_text() == "2" and (out / "notes.txt").read_text() == "mine"
    assert (out / "mine").is_dir() and not (out / "old").exists()
    assert read_marker(out) == {"a.json"}


def test_a_folder_of_only_our_files_is_swapped_whole(tmp_path: Path) -> None:
    out = tmp_path / "run"
    with run_directory(out) as stage:
        _write(stage, {"a.json": "1", "b.json": "1"})
    with run_directory(out) as stage:
        _write(stage, {"b.json": "2"})
    assert sorted(p.name for p in out.iterdir()) == [MARKER, "b.json"]
    assert [p.name for p in tmp_path.iterdir()] == ["run"]  # no .old or .partial left


@pytest.mark.parametrize("setup, message", [
    (lambda d: (d / "project.toml").write_text("[project]\n"), "project folder"),
    (lambda d: (d / "notes.txt").write_text("x"), "did not write"),
])
def test_foreign_folders_are_refused_and_untouched(tmp_path: Path, setup, message: str) -> None:  # type: ignore[no-untyped-def]
    out = tmp_path / "d"
    out.mkdir()
    setup(out)
    before = sorted(p.name for p in out.iterdir())
    with pytest.raises(OutputError, match=message), run_directory(out) as stage:
        _write(stage, {"a.json": "1"})
    assert sorted(p.name for p in out.iterdir()) == before
    assert not (tmp_path / "d.partial").exists()


def test_force_writes_among_other_files_and_a_clash_stops_the_run(tmp_path: Path) -> None:
    out = tmp_path / "d"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    with output_options(force=True), run_directory(out) as stage:
        _write(stage, {"a.json": "1"})
    assert (out / "notes.txt").read_text() == "mine" and read_marker(out) == {"a.json"}
    (out / "b.json").write_text("mine too")
    with pytest.raises(OutputError, match=r"b\.json"), run_directory(out) as stage:
        _write(stage, {"a.json": "2", "b.json": "2"})
    assert (out / "b.json").read_text() == "mine too" and (out / "a.json").read_text() == "1"
    # --force never makes a project folder an output folder
    proj = tmp_path / "proj"
    proj.mkdir()
    (proj / "project.toml").write_text("")
    with output_options(force=True), pytest.raises(OutputError, match="project folder"):
        check_output_dir(proj)


def test_files_paths_below_files_links_and_the_current_folder_are_refused(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    f = tmp_path / "f.txt"
    f.write_text("x")
    link = tmp_path / "link"
    link.symlink_to(tmp_path)
    for path, message in ((f, "existing file"), (f / "x", "below a file"), (link, "symbolic link")):
        with pytest.raises(OutputError, match=message):
            check_output_dir(path)
    (tmp_path / "cwd").mkdir()
    monkeypatch.chdir(tmp_path / "cwd")
    (tmp_path / "cwd" / "x").write_text("")
    for path in (Path("."), Path(".."), tmp_path):
        with output_options(force=True), pytest.raises(OutputError, match="current folder"):
            check_output_dir(path)


def test_an_unwritable_target_is_an_output_error_and_leaves_no_partial(tmp_path: Path) -> None:
    if not Path("/sys").is_dir():  # pragma: no cover - Linux has /sys, where nobody may create folders
        pytest.skip("no /sys")
    with pytest.raises(OutputError, match="cannot write"), run_directory(Path("/sys/kbplanner-test")) as s:
        _write(s, {"a": "1"})
    assert not Path("/sys/kbplanner-test.partial").exists()


def test_a_failed_block_leaves_the_earlier_run_as_it_was(tmp_path: Path) -> None:
    out = tmp_path / "run"
    with run_directory(out) as stage:
        _write(stage, {"a.json": "1"})
    with pytest.raises(RuntimeError), run_directory(out) as stage:
        _write(stage, {"a.json": "2"})
        raise RuntimeError("boom")
    assert (out / "a.json").read_text() == "1" and not (tmp_path / "run.partial").exists()


def test_a_stale_partial_of_a_killed_run_is_replaced_but_a_users_folder_of_that_name_is_not(
        tmp_path: Path) -> None:
    out = tmp_path / "run"
    users = tmp_path / "run.partial"
    users.mkdir()
    (users / "mine.txt").write_text("x")
    with pytest.raises(OutputError, match="staging"), run_directory(out):
        pass
    assert (users / "mine.txt").is_file()


def test_single_file_outputs(tmp_path: Path) -> None:
    mine = tmp_path / "report.ttl"
    mine.write_text("@prefix a: <http://a/> .\n")
    with pytest.raises(OutputError, match="did not write"):
        check_output_file(mine, option="--report")
    with pytest.raises(OutputError, match="is a folder"):
        check_output_file(tmp_path, option="--report")
    with pytest.raises(OutputError, match="below a file"):
        check_output_file(mine / "x.ttl", option="--report")
    ours = tmp_path / "ours.ttl"
    ours.write_text("# Written by kbplanner validate\n")
    check_output_file(ours, option="--report")
    check_output_file(tmp_path / "new.ttl", option="--report")


def test_files_get_the_mode_that_the_umask_gives(tmp_path: Path) -> None:
    old = os.umask(0o022)
    try:
        atomic_write_text(tmp_path / "a.txt", "x")
        os.umask(0o027)
        atomic_write_text(tmp_path / "b.txt", "x")
    finally:
        os.umask(old)
    assert stat.S_IMODE((tmp_path / "a.txt").stat().st_mode) == 0o644
    assert stat.S_IMODE((tmp_path / "b.txt").stat().st_mode) == 0o640


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), -float("inf")])
def test_json_is_strict_and_names_where_a_non_finite_number_is(tmp_path: Path, bad: float) -> None:
    with pytest.raises(KbplannerError, match=r"totals\.speed\[1\]"):
        write_json(tmp_path / "m.json", {"totals": {"speed": [1.0, bad]}})
    assert not (tmp_path / "m.json").exists()
    assert json.loads(json_text({"a": 1.5})) == {"a": 1.5}


def test_the_cli_rewrites_its_own_folder_keeps_the_users_notes_and_force_keeps_a_users_folder(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    from kbplanner.cli import main
    from project_factory import make_project

    make_project(tmp_path / "proj")
    monkeypatch.setenv("KBPLANNER_CACHE_DIR", str(tmp_path / "cache"))
    world = ["world", str(tmp_path / "proj"), "--date", "2022-04-01", "--out"]
    out = tmp_path / "w"
    assert main([*world, str(out)]) == 0
    assert json.loads((out / MARKER).read_text())["command"].startswith("kbplanner world ")
    (out / "notes.txt").write_text("mine")
    assert main([*world, str(out)]) == 0
    assert (out / "notes.txt").read_text() == "mine" and (out / "world.json").is_file()
    users = tmp_path / "users"
    users.mkdir()
    (users / "a.txt").write_text("mine")
    assert main([*world, str(users)]) == 2
    assert "--force" in capsys.readouterr().err and sorted(p.name for p in users.iterdir()) == ["a.txt"]
    assert main([*world, str(users), "--force"]) == 0
    assert (users / "a.txt").read_text() == "mine" and (users / "world.json").is_file()
    json.loads((users / "world.json").read_text(), parse_constant=lambda c: pytest.fail(f"{c} in JSON"))
