"""A6, meshes of the world: element and site-object meshes in the site frame, read once per file."""

from __future__ import annotations

import logging
from collections.abc import Sequence
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, cast

import numpy as np
import trimesh

from kbplanner.core.errors import InputFileError
from kbplanner.world.world_types import (
    SiteObject,
    WorldElement,
    pose_matrix,
)

if TYPE_CHECKING:
    pass

log = logging.getLogger(__name__)


# --------------------------------------------------------------------------------------------
# Meshes
# --------------------------------------------------------------------------------------------


@lru_cache(maxsize=4096)
def _read_mesh(path: str, mtime_ns: int) -> trimesh.Trimesh:
    del mtime_ns  # part of the cache key only: a rewritten file is read again
    mesh = trimesh.load(path, force="mesh", process=False)
    if not isinstance(mesh, trimesh.Trimesh):  # pragma: no cover - force="mesh" gives a Trimesh
        raise InputFileError("not a triangle mesh", file=path, fix="re-run the IFC import")
    return mesh


def load_mesh(path: Path) -> trimesh.Trimesh:
    """A copy of a mesh file's triangles (cached by path and modification time).

    Raises:
        InputFileError: the file is missing or not a mesh.
    """
    try:
        stat = Path(path).stat()
    except OSError:
        raise InputFileError("mesh file not found", file=path,
                             fix="delete the project's .kbplanner-cache directory to import the IFC again"
                             ) from None
    try:
        mesh = _read_mesh(str(path), stat.st_mtime_ns)
    except (ValueError, KeyError, OSError) as exc:
        raise InputFileError(f"cannot read mesh: {exc}", file=path,
                             fix="delete the project's .kbplanner-cache directory to import the IFC again"
                             ) from None
    return mesh.copy()


def element_mesh(element: WorldElement) -> trimesh.Trimesh | None:
    """The element's mesh in the site frame at its current pose (None without geometry)."""
    if element.mesh_path is None:
        return None
    mesh = load_mesh(element.mesh_path)
    if element.is_movable:
        mesh.apply_transform(element.placement)
    return mesh


def element_local_mesh(element: WorldElement) -> trimesh.Trimesh | None:
    """The element's mesh in its own frame (origin at its pose), e.g. for a body or an SDF model."""
    if element.mesh_path is None:
        return None
    mesh = load_mesh(element.mesh_path)
    if element.installed_pose is not None:
        mesh.apply_transform(np.linalg.inv(pose_matrix(element.installed_pose)))
    return mesh


def group_mesh(elements: Sequence[WorldElement]) -> trimesh.Trimesh:
    """The meshes of some static elements merged into one (site frame), in the order given."""
    meshes = [m for m in (element_mesh(e) for e in elements) if m is not None]
    if not meshes:
        return trimesh.Trimesh()
    return cast(trimesh.Trimesh, trimesh.util.concatenate(meshes))


def site_object_mesh(obj: SiteObject) -> trimesh.Trimesh:
    """A site object's box as a mesh in the site frame."""
    return trimesh.creation.box(extents=obj.size, transform=obj.box_center)

