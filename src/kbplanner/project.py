"""The project facade (top of the package): a loaded project with every pipeline step as a method.

:class:`Project` adds the later steps (A3 requirements, A4 validation, B3 robot selection, A6 world,
B1-B4 plan, B5 simulation) to :class:`kbplanner.model.project_data.ProjectData`, the loaded model and
knowledge base that those steps read. The steps themselves never import this module.
"""

from __future__ import annotations

from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING

from kbplanner.core.errors import ProjectError
from kbplanner.model.project_data import (
    CACHE_ENV,
    ProgressFn,
    ProjectData,
    ProjectInfo,
    cache_root,
    file_sha256,
    import_cached,
)
from kbplanner.model.project_manifest import MANIFEST, Calendar, Manifest, Scenario, read_manifest

if TYPE_CHECKING:
    from kbplanner.knowledge.requirements import RequirementsResult
    from kbplanner.knowledge.robot_selection import RobotSelection
    from kbplanner.knowledge.validation import ValidationResult
    from kbplanner.planning.plan_model import Plan
    from kbplanner.simulation.executor import SimulationResult
    from kbplanner.world.world_types import World

__all__ = [
    "CACHE_ENV",
    "MANIFEST",
    "Calendar",
    "Manifest",
    "ProgressFn",
    "Project",
    "ProjectData",
    "ProjectInfo",
    "Scenario",
    "cache_root",
    "file_sha256",
    "import_cached",
    "read_manifest",
]


class Project(ProjectData):
    """A loaded project (see :class:`ProjectData`) with the pipeline's steps as methods.

    Example:
        >>> p = Project.load("data/case_study", scenario="storage-outside")  # doctest: +SKIP
        >>> p.requirements().rows[0]  # doctest: +SKIP
    """

    def requirements(self, task_id: str | None = None) -> RequirementsResult:
        """A3: the additional modeling requirements of the robotized tasks (or one task)."""
        from kbplanner.knowledge.requirements import derive_requirements

        return derive_requirements(self.model, self.kb, task_id=task_id)

    def validate(self) -> ValidationResult:
        """A4: validate the model (well-formedness + requirement shapes); never changes the model."""
        from kbplanner.knowledge.validation import validate_model

        return validate_model(self.model, self.kb)

    def select_robots(self, task_id: str | None = None) -> RobotSelection:
        """B3 preview: every robot of the knowledge base, fit or not, with reasons, for a task."""
        from kbplanner.knowledge.robot_selection import select_robots

        task = task_id or self.default_task()
        if task is None:
            raise ProjectError("no task given and no single robotized task to default to",
                               file=self.manifest.path, fix="name the task (its task_id in the schedule)")
        return select_robots(self.model, self.kb, task, scenario=self.scenario)

    def world(self, at: datetime | str | None = None, task_id: str | None = None) -> World:
        """A6: the simulation world at a date (default: :meth:`world_date` of the task)."""
        from kbplanner.world.build import world_of

        return world_of(self, at, task_id)

    def plan(self, task_id: str | None = None, robot_id: str | None = None, *, refine: bool = True,
             seed: int | None = None, max_elements: int | None = None) -> Plan:
        """B1-B4: the action-level plan of a robotized task; with ``refine``, arm and base poses (B4).

        ``max_elements`` keeps only the first elements of the plan's order (for a quick look).

        Example:
            >>> plan = Project.load("data/case_study", "storage-inside").plan()  # doctest: +SKIP
            >>> len(plan.steps)  # doctest: +SKIP
            44
        """
        from kbplanner.planning.manipulation import refine_plan
        from kbplanner.planning.planner import plan_task

        world = self.world(task_id=task_id)
        plan = plan_task(self, task_id, robot_id, world=world)
        if max_elements is not None:
            plan.keep_first(max_elements)
        if refine and plan.robot_id:
            plan = refine_plan(plan, world, seed=self.manifest.seed if seed is None else seed)
        return plan

    def simulate(self, plan: Plan, *, seed: int | None = None, out_dir: str | Path) -> SimulationResult:
        """B5: execute a (refined) plan in PyBullet and write the run directory ``out_dir``."""
        from kbplanner.simulation.executor import simulate

        return simulate(self, plan, seed=self.manifest.seed if seed is None else seed, out_dir=Path(out_dir))
