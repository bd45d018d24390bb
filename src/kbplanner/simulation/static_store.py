"""B5 set-up, the static bodies' triangles kept on disk: the mesh shapes of the world's static elements
by a content hash of their mesh files, placements and groups.

:func:`kbplanner.simulation.sim_world.load_world` makes one concave mesh body per chunk of a static
group (storey + class), reading every member's mesh file first (trimesh, about a millisecond a file: the
case study's 73 files, some 0.1 s of every run's step). The chunks' triangles depend on those files and
the elements' placements only, so a run keeps them in a folder and the next run on the same world
(``kbplanner simulate`` again, another seed, the early builds' process of a first run,
:mod:`kbplanner.simulation.early_builds`) reads them instead.

- Where: ``static/`` beside the configuration spaces' folder (:func:`kbplanner.world.cspace_store.folder`,
  given by the executor round the world's loading), so on, off and placed as those are
  (``kbplanner --no-cache``, ``KBPLANNER_NO_CACHE=1``: neither read nor written).
- Key: SHA-256 of the format, the versions of NumPy and trimesh (the reader), the source of the loader,
  this module (:data:`_CODE`; the chunk sizes are in it) and the mesh reader
  (:mod:`kbplanner.world.meshes`), and per group its name and per member
  its IRI, mesh file (path, size, modification time: as the process's mesh cache,
  :func:`kbplanner.world.meshes.load_mesh`), whether it is movable and its placement.
- Value: ``KEY.npz`` (no pickle): per chunk its group, its members and the merged vertices (float64)
  and triangles (int64) :func:`kbplanner.simulation.sim_world.load_world` hands PyBullet; read back the
  very arrays (``tests/test_static_store.py``), so the bodies and every output of a run are the same.
- Small worlds only (:data:`MAX_ELEMENTS`, :data:`MAX_BYTES`): a many-storey building's tasks each have
  another world, whose triangles would be written once and never read.
- A file that cannot be read is ignored (the meshes read again); one that cannot be written is logged,
  never an error (written atomically). The newest :data:`KEEP` files are kept.
"""

from __future__ import annotations

import hashlib
import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from kbplanner.core.kept_folder import code_digest, read_arrays, write_arrays
from kbplanner.world import cspace_store
from kbplanner.world.world_types import World

log = logging.getLogger(__name__)

FORMAT = "1"
SUBDIR = "static"
KEEP = 32  # worlds kept (the newest)
#: Worlds with more static elements than this are not kept (a building's every task would write its
#: whole static geometry, tens of megabytes, once: each task's world is another; a process's mesh
#: cache reads each file once anyway), nor chunks over :data:`MAX_BYTES`.
MAX_ELEMENTS = 1000
MAX_BYTES = 16 * 1024 * 1024
_CODE = ("sim_world.py", "static_store.py")

_code_memo: list[bytes] = []
counts = {"read": 0, "written": 0}


@dataclass(frozen=True)
class Chunk:
    """One static body: its group, its members' IRIs, the merged vertices (n x 3) and triangles (m x 3)."""

    group: str
    iris: tuple[str, ...]
    vertices: npt.NDArray[np.float64]
    faces: npt.NDArray[np.int64]


def _code_digest() -> bytes:
    if not _code_memo:
        import trimesh

        from kbplanner.world import meshes

        prefix = f"{FORMAT} numpy {np.__version__} trimesh {trimesh.__version__}"
        here = code_digest(prefix, Path(__file__).resolve().parent, _CODE)
        _code_memo.append(code_digest(here.hex(), Path(meshes.__file__).resolve().parent, ("meshes.py",)))
    return _code_memo[0]


def key(world: World) -> str | None:
    """The content hash the static chunks of ``world`` are kept under (None: a mesh file is missing, or
    more than :data:`MAX_ELEMENTS` static elements)."""
    groups = world.static_groups()
    if sum(len(m) for m in groups.values()) > MAX_ELEMENTS:
        return None
    h = hashlib.sha256(_code_digest())
    for group, members in groups.items():
        h.update(b"group " + group.encode() + b"\0")
        for e in members:
            assert e.mesh_path is not None
            try:
                stat = Path(e.mesh_path).stat()
            except OSError:
                return None  # the loader says what is wrong
            h.update(repr((e.iri, str(e.mesh_path), stat.st_size, stat.st_mtime_ns, e.is_movable)).encode())
            if e.is_movable:
                h.update(np.ascontiguousarray(e.placement, dtype=np.float64).tobytes())
    return h.hexdigest()


def _path(world: World) -> Path | None:
    where = cspace_store.folder()
    k = key(world) if where is not None else None
    return None if where is None or k is None else where.parent / SUBDIR / f"{k}.npz"


def read(world: World) -> list[Chunk] | None:
    """The kept chunks of this world (None: not kept, no folder given, or a damaged file)."""
    path = _path(world)
    if path is None:
        return None
    fields = {"groups": None, "iris": None, "iri_starts": np.int64, "v_starts": np.int64,
              "f_starts": np.int64, "vertices": np.float64, "faces": np.int64}
    got = read_arrays(path, fields, "static bodies")
    if got is None:
        return None
    groups, iris, iri_starts, v_starts, f_starts, vertices, faces = got
    n = len(groups)
    if groups.dtype.kind != "U" or iris.dtype.kind != "U" or any(
            a.shape != (n + 1,) for a in (iri_starts, v_starts, f_starts)) or vertices.ndim != 2 \
            or vertices.shape[1] != 3 or faces.ndim != 2 or faces.shape[1] != 3 \
            or int(v_starts[-1]) != len(vertices) or int(f_starts[-1]) != len(faces) \
            or int(iri_starts[-1]) != len(iris):
        log.warning("ignoring the kept static bodies %s: not a set of chunks", path.name)
        return None
    counts["read"] += 1
    return [Chunk(str(groups[j]), tuple(str(i) for i in iris[iri_starts[j]:iri_starts[j + 1]]),
                  vertices[v_starts[j]:v_starts[j + 1]], faces[f_starts[j]:f_starts[j + 1]])
            for j in range(n)]


def write(world: World, chunks: list[Chunk]) -> None:
    """Keep the chunks of this world (when a folder is given and they are not over :data:`MAX_BYTES`)."""
    if sum(c.vertices.nbytes + c.faces.nbytes for c in chunks) > MAX_BYTES:
        return
    path = _path(world)
    if path is None:
        return
    if write_arrays(path, "static bodies", KEEP, groups=np.array([c.group for c in chunks], dtype=str),
             iris=np.array([i for c in chunks for i in c.iris], dtype=str),
             iri_starts=np.cumsum([0] + [len(c.iris) for c in chunks]).astype(np.int64),
             v_starts=np.cumsum([0] + [len(c.vertices) for c in chunks]).astype(np.int64),
             f_starts=np.cumsum([0] + [len(c.faces) for c in chunks]).astype(np.int64),
             vertices=np.concatenate([c.vertices for c in chunks]).reshape(-1, 3) if chunks
             else np.zeros((0, 3)),
             faces=np.concatenate([c.faces for c in chunks]).reshape(-1, 3) if chunks
             else np.zeros((0, 3), dtype=np.int64)):
        counts["written"] += 1
