"""B5 executable skills: the one table from skill kind (``kbp:SkillKind`` IRI) to implementation.

The kinds are a closed set (:data:`kbplanner.knowledge.skill_kinds.KINDS`, checked before planning:
a skill of another kind is a KnowledgeBaseError there); this table has one implementation per kind
(a test checks both lists agree). A plan read from a file whose step names a kind without an
implementation fails that step ("no executor for skill kind X").

Example:
    >>> from kbplanner.core.vocab import KBP
    >>> SKILLS[str(KBP.NavigationWithObject)].__name__
    'NavigationWithObjectSkill'
    >>> skill_for(str(KBP.FollowToolPath)).__class__.__name__
    'ToolPathSkill'
"""

from __future__ import annotations

from kbplanner.simulation.skills.base import ExecSettings, JointPath, RunContext, Skill, Status
from kbplanner.simulation.skills.fasten import FastenSkill
from kbplanner.simulation.skills.grasp import GraspSkill
from kbplanner.simulation.skills.inspect_view import InspectSkill
from kbplanner.simulation.skills.navigation import NavigationSkill, NavigationWithObjectSkill
from kbplanner.simulation.skills.release import ReleaseSkill
from kbplanner.simulation.skills.tool_path import ToolPathSkill

SKILLS: dict[str, type[Skill]] = {
    cls.kind: cls for cls in (NavigationSkill, NavigationWithObjectSkill, GraspSkill, ReleaseSkill,
                              FastenSkill, ToolPathSkill, InspectSkill)
}


def skill_for(kind: str) -> Skill | None:
    """A new skill object for a skill kind IRI, or None when there is no executor for it."""
    cls = SKILLS.get(kind)
    return cls() if cls is not None else None


__all__ = ["SKILLS", "ExecSettings", "JointPath", "RunContext", "Skill", "Status", "skill_for"]
