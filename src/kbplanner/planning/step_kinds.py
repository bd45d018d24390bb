"""B4 (and B5), what a refined plan is read by: the skill kinds of its steps, its element order, its robot.

The names :mod:`kbplanner.planning.manipulation` (B4) refines a plan with and the simulation
(:mod:`kbplanner.simulation.executor` and the skills) reads it by, without B4's pose search and IK: a
command whose refined plan is kept (:mod:`kbplanner.planning.refine_cache`) imports only these
(issue 14, start-up). :mod:`kbplanner.planning.manipulation` gives them too.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from kbplanner.core.vocab import KBP

if TYPE_CHECKING:
    from kbplanner.planning.plan_model import Plan

KIND_NAVIGATION = str(KBP.Navigation)
KIND_NAVIGATION_WITH_OBJECT = str(KBP.NavigationWithObject)
KIND_GRASP = str(KBP.MoveManipulatorAndGrasp)
KIND_RELEASE = str(KBP.MoveManipulatorAndRelease)
NAVIGATION_KINDS = (KIND_NAVIGATION, KIND_NAVIGATION_WITH_OBJECT)


def elements_in_order(plan: Plan) -> list[str]:
    """Element IRIs in the order of their first step."""
    seen: dict[str, None] = {}
    for s in sorted(plan.steps, key=lambda s: s.step):
        seen.setdefault(s.element, None)
    return list(seen)


def robot_name(plan: Plan) -> str:
    """The robot table's name of the plan's robot: the one whose URDF the plan names, else its id.

    Example:
        >>> from kbplanner.planning.plan_model import Plan
        >>> p = Plan("p", None, "T", "", "S", "husky-ur5", "Husky UR5", "husky_ur5.urdf", "rule")
        >>> robot_name(p)
        'husky_ur5'
    """
    from kbplanner.robot.robot_table import load_robot_specs

    specs = load_robot_specs()
    by_urdf = {s.urdf_name: name for name, s in specs.items()}
    if plan.robot_urdf and plan.robot_urdf.rsplit("/", 1)[-1] in by_urdf:
        return by_urdf[plan.robot_urdf.rsplit("/", 1)[-1]]
    return plan.robot_id.replace("-", "_")
