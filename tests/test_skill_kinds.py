"""Issue 12: the closed set of skill kinds, its executor table and the input roles agree."""

from __future__ import annotations

from rdflib import RDF

from kbplanner.core.vocab import KBP
from kbplanner.knowledge.knowledge_base import load_kb
from kbplanner.knowledge.skill_kinds import _RUNTIME, KINDS, check_skill, declared_roles
from kbplanner.knowledge.task_specs import load_skill
from kbplanner.simulation.skills import SKILLS


def test_every_declared_kind_has_a_contract_and_an_executor_and_nothing_else_does() -> None:
    kb = load_kb()
    declared = set(kb.subjects(RDF.type, KBP.SkillKind))
    assert declared == set(KINDS)
    assert set(SKILLS) == {str(k) for k in KINDS}


def test_the_roles_the_kinds_use_are_the_declared_roles() -> None:
    used = set(_RUNTIME) | {r for c in KINDS.values() for r in c.required | c.accepted}
    assert used == set(declared_roles(load_kb()))


def test_every_shipped_skill_input_has_a_role_its_kind_can_use() -> None:
    kb = load_kb()
    for skill in kb.subjects(RDF.type, KBP.Skill):
        s = load_skill(kb, skill)  # type: ignore[arg-type]
        assert all(i.role is not None for i in s.inputs), s.skill_id
        check_skill(kb, s)
