"""The package layout (issue 15): subpackages by the paper's systems, old module paths still import."""

from __future__ import annotations

import importlib
import pkgutil
import sys
import warnings

import pytest

import kbplanner

SUBPACKAGES = ("core", "knowledge", "model", "world", "robot", "planning", "simulation", "analysis", "scale",
               "cli")


def test_from_kbplanner_import_project_gives_the_facade() -> None:
    from kbplanner import Project
    from kbplanner.model.project_data import ProjectData
    from kbplanner.project import Project as FacadeProject

    assert Project is FacadeProject
    assert issubclass(Project, ProjectData)
    for step in ("requirements", "validate", "select_robots", "world", "plan", "simulate"):
        assert hasattr(Project, step) and not hasattr(ProjectData, step)


@pytest.mark.parametrize("name", SUBPACKAGES)
def test_every_subpackage_says_its_step(name: str) -> None:
    module = importlib.import_module(f"kbplanner.{name}")
    assert module.__doc__ and len(module.__doc__.split()) >= 10


@pytest.mark.parametrize(("old", "new"), sorted(kbplanner.MOVED_MODULES.items()))
def test_old_flat_module_paths_are_the_new_modules(old: str, new: str) -> None:
    if "." in old:  # the old parent package's own warning comes first when it was not imported yet
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            importlib.import_module(f"kbplanner.{old.rsplit('.', 1)[0]}")
    sys.modules.pop(f"kbplanner.{old}", None)  # an alias only: the module itself stays loaded
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        moved = importlib.import_module(f"kbplanner.{old}")
    assert moved is importlib.import_module(f"kbplanner.{new}")
    assert [str(w.message) for w in seen if issubclass(w.category, DeprecationWarning)] == [
        f"kbplanner.{old} moved to kbplanner.{new}; import it from there"]


def test_old_world_and_planning_names_come_from_their_modules() -> None:
    from kbplanner.planning import plan_task
    from kbplanner.planning.planner import plan_task as new_plan_task
    from kbplanner.world import build_world
    from kbplanner.world.build import build_world as new_build_world

    assert plan_task is new_plan_task and build_world is new_build_world
    with pytest.raises(AttributeError):
        kbplanner.world.no_such_name  # type: ignore[attr-defined]  # noqa: B018


def test_every_module_is_in_a_subpackage() -> None:
    top = {m.name for m in pkgutil.iter_modules(kbplanner.__path__)}
    assert top - set(SUBPACKAGES) == {"__main__", "pipeline", "project", "queries"} - (
        {"queries"} - top)


MAX_LINES = 500
SRC = __import__("pathlib").Path(kbplanner.__file__).parent


def test_no_module_over_500_lines_without_a_reason_at_its_top() -> None:
    unexplained = []
    for path in sorted(SRC.rglob("*.py")):
        lines = path.read_text(encoding="utf-8").splitlines()
        if len(lines) > MAX_LINES and not lines[0].startswith("# Over 500 lines: "):
            unexplained.append(f"{path.relative_to(SRC)}: {len(lines)} lines")
    assert not unexplained, unexplained
