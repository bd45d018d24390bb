"""Issue 12: where material waits is declared by the task specification (kbp:materialStoragePath)."""

from __future__ import annotations

from pathlib import Path

import pytest
from rdflib import URIRef

from kb_fixtures import BASE, frame_gid, make_model
from kbplanner.core.errors import KnowledgeBaseError
from kbplanner.core.iris import element_iri, mint
from kbplanner.core.vocab import KBP
from kbplanner.knowledge.knowledge_base import load_kb
from kbplanner.knowledge.material_flow import material_flow
from kbplanner.knowledge.task_specs import task_specification


def test_the_framing_specifications_store_material_by_their_path_and_marking_has_none() -> None:
    kb = load_kb()
    model = make_model(2, storage=True)
    flow = material_flow(kb, task_specification(kb, "I-W-F-#1"))
    assert flow.handles_material
    frames = [element_iri(BASE, frame_gid(i)) for i in (1, 2)]
    stores = {str(s) for el in frames for s in flow.storages(model, el)}
    assert len(stores) == 1  # both frames wait at the one storage of the fixture
    assert not material_flow(kb, task_specification(kb, "L-M-#1")).handles_material


def test_another_path_moves_the_material_with_no_code_change(tmp_path: Path) -> None:
    """A specification linking material to storage another way (the storage points at what it holds)."""
    ext = tmp_path / "held.ttl"
    ext.write_text("""@prefix kbp: <https://w3id.org/kbplanner/ontology#> .
@prefix kb: <https://w3id.org/kbplanner/kb#> .
@prefix owl: <http://www.w3.org/2002/07/owl#> .
@prefix rdfs: <http://www.w3.org/2000/01/rdf-schema#> .
@prefix sh: <http://www.w3.org/ns/shacl#> .
@prefix t: <https://example.org/t#> .
t:holds a owl:ObjectProperty ; rdfs:label "holds" ; rdfs:range kbp:Element .
kb:I-W-F-1 kbp:materialStoragePath [ sh:inversePath t:holds ] .
""")
    kb = load_kb([ext])
    kb.remove((URIRef("https://w3id.org/kbplanner/kb#I-W-F-1"), KBP.materialStoragePath, KBP.storedIn))
    model = make_model(1, storage=False)
    rack = mint(BASE, "site", "rack")
    el = element_iri(BASE, frame_gid(1))
    model.add((rack, URIRef("https://example.org/t#holds"), el))
    flow = material_flow(kb, task_specification(kb, "I-W-F-#1"))
    assert flow.storages(model, el) == [rack]


def test_a_pick_without_a_storage_path_is_an_error_naming_the_specification() -> None:
    kb = load_kb()
    kb.remove((URIRef("https://w3id.org/kbplanner/kb#I-W-F-1"), KBP.materialStoragePath, None))
    with pytest.raises(KnowledgeBaseError) as err:
        material_flow(kb, task_specification(kb, "I-W-F-#1"))
    text = str(err.value)
    assert "I-W-F-#1 picks material but does not say where it waits" in text
    assert "task_specifications.ttl" in text and "kbp:materialStoragePath kbp:storedIn" in text
