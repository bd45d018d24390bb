"""Configuration spaces kept on disk (B4 carry-leg checks, B5 navigation): free maps by a content hash.

:func:`~kbplanner.world.cspace_cache.configuration_space` keeps the spaces it builds in the process;
this module keeps their free maps in a folder as well, so that a second command on the same project
(``kbplanner simulate`` again, another scenario or seed with the same map states) and every other task
of a many-storey building that meets the same map state read them instead of building them again.

- Where: a folder given with :func:`kept_in` (:func:`folder_for` the project's cache entry:
  ``CACHE_ROOT/cspace/`` beside the project cache, ``PROJECT/.kbplanner-cache`` or
  ``$KBPLANNER_CACHE_DIR``; given by the executor around B5 and by ``kbplanner plan`` / ``simulate``
  around B4); none given: nothing is read or written. Off with the project cache (``kbplanner
  --no-cache``, ``KBPLANNER_NO_CACHE=1``).
- Key: SHA-256 of the format, the versions of NumPy and SciPy (the FFT), the source of the code that
  builds a space (:mod:`~kbplanner.world.footprint`, :mod:`~kbplanner.world.cspace_cache`,
  :mod:`~kbplanner.world.occupancy`, this module), the footprint's rectangles, the yaw bins, the margin,
  the resolution, the grid's shape and its occupied cells. The origin is not part of it: a space's free
  maps depend on the cells only.
- Value: ``KEY.npy``, the free maps packed 8 cells a byte (:func:`numpy.packbits`); read back they are
  the very arrays a build gives (``tests/test_cspace_store.py``).
- A file that cannot be read, or holds another shape, is ignored and the space is built; one that
  cannot be written is logged, never an error (written atomically: two commands at once each see a
  whole file or none). The newest files up to :data:`BUDGET_BYTES` are kept (looked at on a process's
  first write and every :data:`TRIM_EVERY` writes after it).

Example:
    >>> import tempfile
    >>> import numpy as np
    >>> from kbplanner.world.footprint import ConfigurationSpace, Footprint, Rect
    >>> occ = np.zeros((30, 40), dtype=bool); occ[:, 25] = True
    >>> grid = OccupancyGrid(occ, origin=(0.0, 0.0), resolution=0.05)
    >>> fp = Footprint((Rect(0, 0, 0.5, 0.3),))
    >>> free = ConfigurationSpace.build(grid, fp).free
    >>> with tempfile.TemporaryDirectory() as tmp, kept_in(Path(tmp)):
    ...     write(grid, fp, 72, 0.0, free)
    ...     bool(np.array_equal(read(grid, fp, 72, 0.0), free))
    True
"""

from __future__ import annotations

import hashlib
import io
import logging
from pathlib import Path

import numpy as np
import numpy.typing as npt

from kbplanner.core.kept_folder import KeptFolder, code_digest
from kbplanner.core.outputs import atomic_write_bytes
from kbplanner.world.footprint import Footprint
from kbplanner.world.occupancy import OccupancyGrid

log = logging.getLogger(__name__)

FORMAT = "1"
SUBDIR = "cspace"
#: Bytes of kept files at most (the newest are kept); a case-study run writes about 5 MB.
BUDGET_BYTES = 256 * 1024 * 1024
TRIM_EVERY = 16  # writes between two looks at the folder's size
_CODE = ("footprint.py", "cspace_fft.py", "cspace_cache.py", "occupancy.py", "cspace_store.py")

_kept = KeptFolder()
_code_memo: list[bytes] = []
counts = {"read": 0, "written": 0}


kept_in = _kept.kept_in


def folder_for(cache_entry: Path | None) -> Path | None:
    """The folder beside a project cache entry (:func:`kbplanner.model.project_cache.entry_dir`:
    ``ROOT/project/KEY`` gives ``ROOT/cspace``); None for a project without one (``--no-cache``)."""
    return None if cache_entry is None else Path(cache_entry).parent.parent / SUBDIR


def folder() -> Path | None:
    """The folder given by the innermost :func:`kept_in`, or None."""
    return _kept.current()


def _code_digest() -> bytes:
    if not _code_memo:
        import scipy

        prefix = f"{FORMAT} numpy {np.__version__} scipy {scipy.__version__}"
        _code_memo.append(code_digest(prefix, Path(__file__).resolve().parent, _CODE))
    return _code_memo[0]


def key(grid: OccupancyGrid, footprint: Footprint, n_yaw_bins: int, margin_m: float) -> str:
    """The content hash a space's free maps are kept under (see module docstring)."""
    h = hashlib.sha256(_code_digest())
    h.update(repr((footprint.rects, int(n_yaw_bins), float(margin_m), float(grid.resolution),
                   tuple(grid.occupied.shape))).encode())
    h.update(np.ascontiguousarray(grid.occupied, dtype=bool).tobytes())
    return h.hexdigest()


def _path(grid: OccupancyGrid, footprint: Footprint, n_yaw_bins: int, margin_m: float) -> Path | None:
    where = folder()
    return None if where is None else where / f"{key(grid, footprint, n_yaw_bins, margin_m)}.npy"


def read(grid: OccupancyGrid, footprint: Footprint, n_yaw_bins: int,
         margin_m: float) -> npt.NDArray[np.bool_] | None:
    """The kept free maps (n_yaw_bins, ny, nx) of this grid and footprint, or None."""
    path = _path(grid, footprint, n_yaw_bins, margin_m)
    if path is None:
        return None
    try:
        packed = np.load(path, allow_pickle=False)
    except FileNotFoundError:
        return None
    except (OSError, ValueError, EOFError) as exc:  # a damaged file: built again and replaced
        log.warning("ignoring the kept configuration space %s: %s", path.name, exc)
        return None
    shape = (int(n_yaw_bins), *grid.occupied.shape)
    n = int(np.prod(shape))
    if packed.dtype != np.uint8 or packed.ndim != 1 or packed.size != (n + 7) // 8:
        log.warning("ignoring the kept configuration space %s: not %s cells", path.name, shape)
        return None
    counts["read"] += 1
    return np.unpackbits(packed, count=n).view(np.bool_).reshape(shape)  # 0/1 bytes: bools, no copy


def write(grid: OccupancyGrid, footprint: Footprint, n_yaw_bins: int, margin_m: float,
          free: npt.NDArray[np.bool_]) -> None:
    """Keep the free maps of this grid and footprint (when a folder is given)."""
    path = _path(grid, footprint, n_yaw_bins, margin_m)
    if path is None:
        return
    buf = io.BytesIO()
    np.save(buf, np.packbits(np.ascontiguousarray(free).reshape(-1)), allow_pickle=False)
    try:
        atomic_write_bytes(path, buf.getvalue())
        counts["written"] += 1
        if (counts["written"] - 1) % TRIM_EVERY == 0:  # the first write of a process, then every few
            _trim(path)
    except OSError as exc:
        log.warning("could not keep the configuration space in %s: %s", path.parent, exc)


def _trim(newest: Path) -> None:
    """Remove the oldest files past :data:`BUDGET_BYTES` (never ``newest``, the file just written)."""
    files = []
    for p in newest.parent.glob("*.npy"):
        if p == newest:
            continue
        try:
            st = p.stat()
        except OSError:
            continue
        files.append((st.st_mtime_ns, p.name, st.st_size, p))
    total = newest.stat().st_size
    for _, _, size, p in sorted(files, reverse=True):
        total += size
        if total > BUDGET_BYTES:
            p.unlink(missing_ok=True)
