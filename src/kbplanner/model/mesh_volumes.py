"""IFC import, geometry: element volumes from their meshes, optionally in a second process.

:func:`mesh_volume` is the volume of one closed mesh (or of its closed pieces). :class:`VolumePool`
computes them in one spawned process while the import's geometry iterator is still triangulating the
next elements (the cold import of a large building, ``kbplanner run``'s first load, is on the critical
path before any task): meshes are sent in batches as they arrive, and when the import needs the
volumes, the batches the process has not begun are taken back and computed here. The process gets the
mesh's own vertex and face arrays and builds the same mesh from them (``process=False``: nothing
merged or reordered), so every volume is the float :func:`mesh_volume` gives here.

A module without ifcopenshell: the spawned process imports only numpy and trimesh.
"""

from __future__ import annotations

import logging
import multiprocessing
from concurrent.futures import Future, ProcessPoolExecutor
from types import TracebackType

import numpy as np
import trimesh

log = logging.getLogger(__name__)

Volume = tuple[float, str] | None
Batch = list[tuple[str, np.ndarray, np.ndarray]]

#: Meshes per batch sent to the process (a stud-frame panel: a few hundred vertices).
BATCH = 48


def mesh_volume(mesh: trimesh.Trimesh) -> Volume:
    """Volume (m3) of a closed mesh, or the sum over its pieces when every piece is closed."""
    with np.errstate(divide="ignore", invalid="ignore"):  # flat pieces have zero volume
        if mesh.is_watertight:
            return abs(float(mesh.volume)), "closed mesh"
        pieces = mesh.split(only_watertight=False)
        if len(pieces) > 1 and all(p.is_watertight for p in pieces):
            return sum(abs(float(p.volume)) for p in pieces), f"{len(pieces)} closed mesh pieces"
    return None


def volumes_of(batch: Batch) -> dict[str, Volume]:
    """:func:`mesh_volume` of each (GlobalId, vertices, faces) of a batch, the mesh built as it was."""
    return {guid: mesh_volume(trimesh.Trimesh(vertices=v, faces=f, process=False)) for guid, v, f in batch}


class VolumePool:
    """Volumes of the meshes :meth:`add`-ed, computed in ``processes`` spawned processes (0: here, when
    :meth:`volumes` is called). A process that cannot be started leaves the work to this one."""

    def __init__(self, processes: int) -> None:
        self._batch: Batch = []
        self._sent: list[tuple[Batch, Future[dict[str, Volume]]]] = []
        self._executor: ProcessPoolExecutor | None = None
        if processes > 0:
            try:
                spawn = multiprocessing.get_context("spawn")
                self._executor = ProcessPoolExecutor(processes, mp_context=spawn)
            except OSError as exc:
                log.info("volumes in this process (no second process: %s)", exc)

    def __enter__(self) -> VolumePool:
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    def close(self) -> None:
        if self._executor is not None:
            self._executor.shutdown(wait=True, cancel_futures=True)
            self._executor = None

    def add(self, guid: str, mesh: trimesh.Trimesh) -> None:
        """Queue a mesh's volume; a full batch goes to the process."""
        self._batch.append((guid, mesh.vertices.view(np.ndarray), mesh.faces.view(np.ndarray)))
        if len(self._batch) >= BATCH:
            self._send()

    def _send(self) -> None:
        batch, self._batch = self._batch, []
        if self._executor is None or not batch:
            self._batch = batch
            return
        try:
            self._sent.append((batch, self._executor.submit(volumes_of, batch)))
        except RuntimeError:  # the pool broke (a killed process): this process does the rest
            self._executor = None
            self._batch = batch

    def volumes(self) -> dict[str, Volume]:
        """Every queued mesh's volume by GlobalId; batches not begun elsewhere are computed here."""
        out: dict[str, Volume] = volumes_of(self._batch)
        self._batch = []
        for batch, future in reversed(self._sent):  # the last sent are the least likely begun
            if future.cancel():
                out.update(volumes_of(batch))
        for batch, future in self._sent:
            if future.cancelled():
                continue
            try:
                out.update(future.result())
            except Exception as exc:  # a process that died: the same work here
                log.info("volumes in this process (%s: %s)", type(exc).__name__, exc)
                out.update(volumes_of(batch))
        self._sent = []
        self.close()
        return out
