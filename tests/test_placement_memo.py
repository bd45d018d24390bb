"""The import's placement memo (issue 14, the cold import of the 10 x 8 building): each product's
placement with the memo is ifcopenshell's ``get_local_placement`` to the bit, and a broken placement
fails the same way."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import ifcopenshell
import numpy as np

from kbplanner.model import ifc_geometry as geo
from kbplanner.model.ifc_open import open_ifc


def _matrix(product: Any, memo: dict[int, np.ndarray] | None) -> bytes | str | None:
    try:
        m = geo.placement_matrix(product, 0.001, memo)
    except Exception as exc:
        return f"{type(exc).__name__}: {exc}"
    return None if m is None else m.tobytes()


def test_placements_with_the_memo_are_those_without_to_the_bit(duplex_ifc: Path) -> None:
    f = open_ifc(duplex_ifc)
    memo: dict[int, np.ndarray] = {}
    products = f.by_type("IfcProduct")
    assert len(products) > 100
    assert [_matrix(p, memo) for p in products] == [_matrix(p, None) for p in products]
    assert 0 < len(memo) <= len(products) + 10


def test_a_grid_placement_fails_as_without_the_memo() -> None:
    f = ifcopenshell.file(schema="IFC4")
    wall = f.createIfcWall(ifcopenshell.guid.new(), ObjectPlacement=f.createIfcGridPlacement())
    assert _matrix(wall, {}) == _matrix(wall, None) and isinstance(_matrix(wall, None), str)
