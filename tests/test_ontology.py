"""The ontology lints itself: every term used anywhere is declared, the vocabulary module is current,
and owlready2 loads the ontology and HermiT finds it consistent."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from rdflib import RDF, Graph, URIRef

from kbplanner.core import vocab_gen
from kbplanner.core.resources import data_dir, ontology_files

KBP = vocab_gen.KBP_NS
BOT = vocab_gen.BOT_NS
REPO = Path(__file__).resolve().parents[1]


def _ontology() -> Graph:
    g = Graph()
    for p in ontology_files():
        g.parse(p, format="turtle")
    return g


def _declared(g: Graph) -> set[URIRef]:
    return {s for s in g.subjects(RDF.type, None) if isinstance(s, URIRef)}


def _turtle_files() -> list[Path]:
    files: list[Path] = []
    for d in ("ontology", "shapes", "data", "tests"):
        files += sorted((REPO / d).rglob("*.ttl"))
    return [f for f in files if ".kbplanner-cache" not in f.parts]


def test_every_kbp_and_bot_term_used_in_turtle_files_is_declared() -> None:
    declared = _declared(_ontology())
    missing: dict[str, set[str]] = {}
    for path in _turtle_files():
        g = Graph().parse(path, format="turtle")
        for triple in g:
            for term in triple:
                if isinstance(term, URIRef) and str(term).startswith((KBP, BOT)) and term not in declared:
                    missing.setdefault(str(path.relative_to(REPO)), set()).add(str(term))
    assert not missing, f"undeclared terms: {missing}"


def test_every_kbp_term_used_in_sparql_queries_is_declared() -> None:
    import re

    declared = {str(t) for t in _declared(_ontology())}
    queries = sorted((REPO / "src" / "kbplanner" / "queries").glob("*.rq"))
    assert queries
    undeclared = set()
    for q in queries:
        for local in re.findall(r"\bkbp:([A-Za-z_][A-Za-z0-9_]*)", q.read_text()):
            if KBP + local not in declared:
                undeclared.add(f"{q.name}: kbp:{local}")
    assert not undeclared, sorted(undeclared)


def test_vocab_module_equals_a_fresh_generation() -> None:
    text = vocab_gen.render(vocab_gen.ontology_graph(data_dir("ontology")))
    current = (REPO / "src" / "kbplanner" / "core" / "vocab.py").read_text()
    assert text == current, "run: python -m kbplanner.core.vocab_gen"


def test_closed_vocabulary_rejects_a_typo() -> None:
    from kbplanner.core.vocab import KBP as K

    assert str(K.installedPose).endswith("#installedPose")
    with pytest.raises(AttributeError):
        _ = K.instaledPose


@pytest.mark.skipif(shutil.which("java") is None, reason="HermiT needs a Java runtime")
def test_owlready2_loads_the_ontology_and_hermit_finds_it_consistent(tmp_path: Path) -> None:
    import owlready2

    xml = tmp_path / "kbplanner.owl"
    _ontology().serialize(xml, format="xml")
    world = owlready2.World()
    onto = world.get_ontology(xml.as_uri()).load()
    assert len(list(onto.classes())) > 20
    with onto:
        owlready2.sync_reasoner_hermit(world, infer_property_values=False, debug=0)
    inconsistent = list(world.inconsistent_classes())
    assert inconsistent == []
