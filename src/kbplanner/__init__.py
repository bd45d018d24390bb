"""kbplanner: plan and simulate construction robot work inside a 4D BIM model.

The pipeline follows the information flow of Oyediran et al. (A1-A6, B1-B5), and the package is laid
out by the paper's three systems, each layer importing only the ones below it:

- :mod:`kbplanner.core`: errors, resources, RDF I/O, vocabulary, named queries, stores, outputs;
- :mod:`kbplanner.knowledge`: the construction robot knowledge base (A1-A5, B3);
- :mod:`kbplanner.model`: the 4D BIM environment (IFC, schedule, project files);
- :mod:`kbplanner.world`, :mod:`kbplanner.robot`, :mod:`kbplanner.planning`,
  :mod:`kbplanner.simulation`: the robot simulation environment (A6, B1-B5);
- :mod:`kbplanner.analysis`: run records, proximity, comparison, report;
- :mod:`kbplanner.scale`: generated buildings, sweeps, whole-building task runs;
- :mod:`kbplanner.project` (the :class:`Project` facade), :mod:`kbplanner.pipeline`, :mod:`kbplanner.cli`.

See ``docs/architecture.md``. ``from kbplanner import Project`` loads the facade on first use, so that
``import kbplanner`` stays cheap.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import sys
import warnings
from types import ModuleType
from typing import TYPE_CHECKING, Any

from kbplanner.core.errors import KbplannerError

if TYPE_CHECKING:
    from kbplanner.project import Project

from kbplanner.core.version import __version__

__all__ = ["KbplannerError", "Project", "__version__"]


# Module paths of 0.1's flat layout -> their home now. ``import kbplanner.run_record`` (as the docs of
# 0.1 showed) still works and warns (DeprecationWarning); new code imports the new path.
MOVED_MODULES: dict[str, str] = {
    "arm_analytic_ik": "robot.arm_analytic_ik",
    "arm_ik": "robot.arm_ik",
    "binding_paths": "knowledge.binding_paths",
    "building_generator": "scale.building_generator",
    "carry": "planning.carry",
    "comparison": "analysis.comparison",
    "element_order": "planning.element_order",
    "errors": "core.errors",
    "executor": "simulation.executor",
    "footprint": "world.footprint",
    "ifc_geometry": "model.ifc_geometry",
    "ifc_import": "model.ifc_import",
    "ifc_semantics": "model.ifc_semantics",
    "ifc_turtle": "model.ifc_turtle",
    "iris": "core.iris",
    "jobsite": "knowledge.jobsite",
    "keyframes": "simulation.keyframes",
    "knowledge_base": "knowledge.knowledge_base",
    "lidar": "robot.lidar",
    "manipulation": "planning.manipulation",
    "named_queries": "core.named_queries",
    "navigation": "simulation.navigation",
    "occupancy": "world.occupancy",
    "outputs": "core.outputs",
    "plan_model": "planning.plan_model",
    "plan_rdf": "planning.plan_rdf",
    "plots": "analysis.plots",
    "proximity": "analysis.proximity",
    "rdf_io": "core.rdf_io",
    "recorder": "simulation.recorder",
    "report": "analysis.report",
    "report_doc": "analysis.report_doc",
    "requirement_shapes": "knowledge.requirement_shapes",
    "requirements": "knowledge.requirements",
    "resources": "core.resources",
    "robot_model": "robot.robot_model",
    "robot_selection": "knowledge.robot_selection",
    "run_record": "analysis.run_record",
    "schedule": "model.schedule",
    "schedule_csv": "model.schedule_csv",
    "schedule_fit": "analysis.schedule_fit",
    "schedule_ifc": "model.schedule_ifc",
    "schedule_model": "model.schedule_model",
    "sim_env": "simulation.sim_env",
    "sim_world": "simulation.sim_world",
    "skill_inputs": "planning.skill_inputs",
    "skills": "simulation.skills",
    "skills.base": "simulation.skills.base",
    "skills.grasp": "simulation.skills.grasp",
    "skills.navigation": "simulation.skills.navigation",
    "skills.release": "simulation.skills.release",
    "stores": "core.stores",
    "stud_frames": "model.stud_frames",
    "sweep": "scale.sweep",
    "tables": "core.tables",
    "task_runs": "scale.task_runs",
    "task_specs": "knowledge.task_specs",
    "validation": "knowledge.validation",
    "vocab": "core.vocab",
    "vocab_gen": "core.vocab_gen",
    "workers": "simulation.workers",
    "world_exports": "world.exports",
}


class _MovedModuleLoader(importlib.abc.Loader):
    """Loads an old module path as the module at its new path (the same module object)."""

    def __init__(self, new_name: str) -> None:
        self.new_name = new_name

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType | None:  # noqa: ARG002
        return None

    def exec_module(self, module: ModuleType) -> None:
        warnings.warn(f"{module.__name__} moved to {self.new_name}; import it from there",
                      DeprecationWarning, stacklevel=2)
        sys.modules[module.__name__] = importlib.import_module(self.new_name)


class _MovedModuleFinder(importlib.abc.MetaPathFinder):
    """Finds the old flat module paths of :data:`MOVED_MODULES`."""

    def find_spec(self, fullname: str, path: Any = None, target: Any = None  # noqa: ARG002
                  ) -> importlib.machinery.ModuleSpec | None:
        prefix = "kbplanner."
        if not fullname.startswith(prefix) or fullname[len(prefix):] not in MOVED_MODULES:
            return None
        new_name = prefix + MOVED_MODULES[fullname[len(prefix):]]
        return importlib.machinery.ModuleSpec(fullname, _MovedModuleLoader(new_name))


if not any(isinstance(f, _MovedModuleFinder) for f in sys.meta_path):
    sys.meta_path.insert(0, _MovedModuleFinder())


def __getattr__(name: str) -> Any:
    """``kbplanner.Project`` imported on first use (PEP 562)."""
    if name == "Project":
        from kbplanner.project import Project

        return Project
    raise AttributeError(f"module 'kbplanner' has no attribute {name!r}")
