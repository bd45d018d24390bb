"""Mesh volumes in a second process (issue 14, the cold import of the 10 x 8 building): the same floats as
computed in the importing process, batches the process has not begun taken back, and the same import."""

from __future__ import annotations

from pathlib import Path

import pytest
import trimesh

from kbplanner.core.iris import base_iri
from kbplanner.model import ifc_import
from kbplanner.model.mesh_volumes import VolumePool, mesh_volume


def _meshes() -> dict[str, trimesh.Trimesh]:
    closed = trimesh.creation.box((1.0, 2.0, 0.5))
    two = trimesh.util.concatenate([trimesh.creation.box((0.1, 0.1, 2.0)),
                                    trimesh.creation.box((0.1, 0.1, 2.0)).apply_translation((1.0, 0.0, 0.0))])
    open_ = trimesh.Trimesh(vertices=closed.vertices, faces=closed.faces[:-2], process=False)
    out = {"closed": closed, "two pieces": two, "open": open_}
    for k in range(150):  # several batches, so that some are sent and some taken back
        out[f"cyl{k:03d}"] = trimesh.creation.cylinder(radius=0.05 + k * 1e-3, height=1.0 + k * 1e-2)
    return out


@pytest.mark.parametrize("processes", [0, 1])
def test_the_pool_gives_the_volumes_computed_here(processes: int) -> None:
    meshes = _meshes()
    with VolumePool(processes) as pool:
        for guid, mesh in meshes.items():
            pool.add(guid, mesh)
        got = pool.volumes()
    assert got == {guid: mesh_volume(mesh) for guid, mesh in meshes.items()}
    assert got["open"] is None and got["closed"] is not None and abs(got["closed"][0] - 1.0) < 1e-12


@pytest.mark.slow
def test_an_import_with_a_volume_process_writes_the_same_files(duplex_ifc: Path, tmp_path: Path,
                                                                monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(ifc_import, "MIN_POOLED", 0)
    here = ifc_import.import_ifc(duplex_ifc, tmp_path / "here", base=base_iri("duplex"))
    pooled = ifc_import.import_ifc(duplex_ifc, tmp_path / "pooled", base=base_iri("duplex"),
                                   volume_processes=1)
    assert here.counts == pooled.counts and here.skipped == pooled.skipped
    files = sorted(p.relative_to(tmp_path / "here") for p in (tmp_path / "here").rglob("*") if p.is_file())
    assert files and all((tmp_path / "here" / f).read_bytes() == (tmp_path / "pooled" / f).read_bytes()
                         for f in files)
