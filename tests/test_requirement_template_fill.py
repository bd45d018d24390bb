"""``requirements --template`` (issue 10): the skeleton validates once its placeholders are filled.

The template mints a material storage with everything validation asks of one (shapes/model.ttl: an
installed pose and a positive size, besides the pickup location the requirement names); filling
every placeholder with a real value gives a model that conforms and has no requirement left.
"""

from __future__ import annotations

from rdflib import RDF, XSD, Graph, Literal

from kb_fixtures import make_model
from kbplanner.core.vocab import KBP
from kbplanner.knowledge.knowledge_base import load_kb
from kbplanner.knowledge.requirements import derive_requirements
from kbplanner.knowledge.validation import validate_model

SIZES = {KBP.sizeX: 2.6, KBP.sizeY: 0.8, KBP.sizeZ: 0.1}


def _fill(skeleton: Graph, model: Graph) -> Graph:
    """Every placeholder replaced: sizes of a frame stack, poses at the middle of the site extent."""
    box = next(model.objects(None, KBP.siteExtent))
    mid = {KBP.x: (float(model.value(box, KBP.minX)) + float(model.value(box, KBP.maxX))) / 2,
           KBP.y: (float(model.value(box, KBP.minY)) + float(model.value(box, KBP.maxY))) / 2}
    out = Graph()
    for s, p, o in skeleton:
        if isinstance(o, Literal) and o.datatype == XSD.double:
            value = SIZES.get(p, mid.get(p, 0.0))  # type: ignore[call-overload]
            o = Literal(value, datatype=XSD.double)
        out.add((s, p, o))
    return out


def test_the_filled_template_validates() -> None:
    kb = load_kb()
    model = make_model()
    skeleton = Graph().parse(data=derive_requirements(model, kb).template(), format="turtle")
    storages = list(skeleton.subjects(RDF.type, KBP.MaterialStorage))
    assert len(storages) == 1
    storage = storages[0]
    have = {p for p, _ in skeleton.predicate_objects(storage)}
    assert have >= {KBP.installedPose, *SIZES, KBP.pickupLocation}
    assert all(float(o) == 1.0 for p in SIZES for o in skeleton.objects(storage, p))  # placeholders
    filled = make_model() + _fill(skeleton, model)
    result = validate_model(filled, kb)
    assert result.conforms, result.text()
    assert derive_requirements(filled, kb).requirements == []
