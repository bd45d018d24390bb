"""B5 executable skills: the one table from skill kind (``kbp:SkillKind`` IRI) to implementation.

The executor looks a step's ``skill_kind`` up in :data:`SKILLS`; a kind without an implementation
is a failed step ("no executor for skill kind X"), not an error. Adding a skill = one module with a
:class:`~kbplanner.simulation.skills.base.Skill` subclass and one line here.

Example:
    >>> from kbplanner.core.vocab import KBP
    >>> SKILLS[str(KBP.NavigationWithObject)].__name__
    'NavigationWithObjectSkill'
    >>> skill_for(str(KBP.LineMarking)) is None
    True
"""

from __future__ import annotations

from kbplanner.simulation.skills.base import ExecSettings, JointPath, RunContext, Skill, Status
from kbplanner.simulation.skills.grasp import GraspSkill
from kbplanner.simulation.skills.navigation import NavigationSkill, NavigationWithObjectSkill
from kbplanner.simulation.skills.release import ReleaseSkill

SKILLS: dict[str, type[Skill]] = {
    cls.kind: cls for cls in (NavigationSkill, NavigationWithObjectSkill, GraspSkill, ReleaseSkill)
}


def skill_for(kind: str) -> Skill | None:
    """A new skill object for a skill kind IRI, or None when there is no executor for it."""
    cls = SKILLS.get(kind)
    return cls() if cls is not None else None


__all__ = ["SKILLS", "ExecSettings", "JointPath", "RunContext", "Skill", "Status", "skill_for"]
