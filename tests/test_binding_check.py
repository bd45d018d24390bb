"""Malformed input bindings (issue 12): each form is a KnowledgeBaseError naming the file, the binding
and the fix when the knowledge base is loaded, and exit 2 from the CLI, never a pyshacl traceback."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from kbplanner.core.errors import KnowledgeBaseError
from kbplanner.knowledge.binding_check import check_bindings
from kbplanner.knowledge.knowledge_base import load_kb
from kbplanner.knowledge.task_specs import task_specification
from project_factory import make_project

PREFIXES = """@prefix kbp: <https://w3id.org/kbplanner/ontology#> .
@prefix kb: <https://w3id.org/kbplanner/kb#> .
@prefix ext: <https://example.org/ext#> .
@prefix rdfs: <http://www.w3.org/2000/01/rdf-schema#> .
@prefix sh: <http://www.w3.org/ns/shacl#> .
@prefix rdf: <http://www.w3.org/1999/02/22-rdf-syntax-ns#> .
kb:X a kbp:TaskSpecification ; kbp:specificationId "X-#1" ; kbp:hasAction kb:X-a1 .
kb:X-a1 a kbp:Action ; kbp:order 1 ; rdfs:label "go" ; kbp:usesSkill kb:NV-1 ; kbp:hasBinding kb:X-b .
"""

# form -> (binding body, words the message must hold, words of the fix)
MALFORMED = {
    "two paths": ("kbp:bindsInput kb:NV-1-destination ; kbp:bindingPath kbp:installedPose , kbp:markingStart",
                  "has 2 kbp:bindingPath values", "keep one kbp:bindingPath"),
    "two list paths": ("kbp:bindsInput kb:NV-1-destination ; "
                       "kbp:bindingPath ( kbp:storedIn kbp:pickupLocation ) , ( kbp:installedPose )",
                       "has 2 kbp:bindingPath values", "keep one kbp:bindingPath"),
    "unknown property": ("kbp:bindsInput kb:NV-1-destination ; "
                         "kbp:bindingPath ( kbp:storedIn ext:pickupSpot )",
                         "undeclared property ext:pickupSpot", "declare ext:pickupSpot"),
    "empty path": ("kbp:bindsInput kb:NV-1-destination ; kbp:bindingPath ()", "binding path is an empty list",
                   "give at least one property"),
    "no path": ("kbp:bindsInput kb:NV-1-destination", "has no kbp:bindingPath", "add kbp:bindingPath"),
    "literal path": ('kbp:bindsInput kb:NV-1-destination ; kbp:bindingPath "kbp:installedPose"',
                     "not a SHACL property path", "use a property IRI"),
    "two inputs": ("kbp:bindsInput kb:NV-1-destination , kb:NV-1-map ; kbp:bindingPath kbp:installedPose",
                   "has 2 kbp:bindsInput values", "exactly one kbp:bindsInput"),
    "two path starts": ("kbp:bindsInput kb:NV-1-destination ; kbp:bindingPath kbp:installedPose ; "
                        "kbp:pathStart kbp:StartAtElement , kbp:StartAtTask", "kbp:pathStart", "at most one"),
    "mixed path forms": ("kbp:bindsInput kb:NV-1-destination ; "
                         "kbp:bindingPath [ sh:inversePath kbp:storedIn ; sh:zeroOrMorePath kbp:storedIn ]",
                         "mixes SHACL path forms", "exactly one of sh:inversePath"),
    "broken list": ("kbp:bindsInput kb:NV-1-destination ; kbp:bindingPath ext:cell .\n"
                    "ext:cell rdf:first kbp:storedIn ; rdf:rest ext:cell2 .\n"
                    "ext:cell2 rdf:first kbp:pickupLocation", "broken RDF list", "Turtle list syntax"),
}


def _ext(tmp_path: Path, body: str) -> Path:
    p = tmp_path / "ext.ttl"
    p.write_text(PREFIXES + f"kb:X-b a kbp:InputBinding ; {body} .\n", encoding="utf-8")
    return p


@pytest.mark.parametrize("form", sorted(MALFORMED))
def test_each_malformed_binding_names_the_file_the_binding_and_the_fix(tmp_path: Path, form: str) -> None:
    body, problem, fix = MALFORMED[form]
    ext = _ext(tmp_path, body)
    kb = load_kb([ext])
    for check in (lambda: check_bindings(kb), lambda: task_specification(kb, "X-#1")):
        with pytest.raises(KnowledgeBaseError) as err:
            check()
        text = str(err.value)
        assert str(ext) in text and "kb:X-b" in text and problem in text, text
        assert fix in (err.value.fix or ""), text


def test_an_action_that_binds_one_input_twice_is_an_error(tmp_path: Path) -> None:
    ext = tmp_path / "ext.ttl"
    ext.write_text(PREFIXES + "kb:X-a1 kbp:hasBinding kb:X-c .\n"
                   "kb:X-b a kbp:InputBinding ; kbp:bindsInput kb:NV-1-destination ; "
                   "kbp:bindingPath kbp:installedPose .\n"
                   "kb:X-c a kbp:InputBinding ; kbp:bindsInput kb:NV-1-destination ; "
                   "kbp:bindingPath kbp:markingStart .\n", encoding="utf-8")
    with pytest.raises(KnowledgeBaseError, match="binds input 'destination' of NV-1 twice"):
        task_specification(load_kb([ext]), "X-#1")


def test_the_shipped_knowledge_base_has_only_well_formed_bindings() -> None:
    assert check_bindings(load_kb()) >= 12  # at least 4 + 4 wall framing, 4 layout marking


def test_a_binding_with_two_paths_in_a_project_is_exit_2_with_one_message(tmp_path: Path) -> None:
    proj = tmp_path / "proj"
    make_project(proj)
    _ext(proj, MALFORMED["two paths"][0])
    toml = proj / "project.toml"
    toml.write_text(toml.read_text().replace("[model]\n", '[model]\nknowledge_base = ["ext.ttl"]\n', 1))
    out = subprocess.run([sys.executable, "-m", "kbplanner.cli", "requirements", str(proj)],
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 2, out.stderr
    assert "Traceback" not in out.stderr and "ShapeLoadError" not in out.stderr
    assert "ext.ttl" in out.stderr and "kb:X-b" in out.stderr and "fix:" in out.stderr
