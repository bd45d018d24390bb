"""Seals on the pickles kbplanner keeps (all steps): a pickle is read only if this user's kbplanner wrote it.

The project cache (``graphs.pickle``) and the prepared-query cache keep pickles, and unpickling runs
whatever the file says. A project folder may come from elsewhere (a zip, a shared drive) with its
``.kbplanner-cache``: so every pickle is written with an HMAC-SHA256 under a key only this user has
(32 random bytes in ``$XDG_CACHE_HOME/kbplanner/seal.key``, ``~/.cache/kbplanner/seal.key``, mode 600,
made on first use), and a pickle whose seal does not match is never unpickled (the cache falls back to
reading its inputs, and replaces it). Where no key can be kept (a read-only home) nothing is sealed:
the callers then keep no pickles.
"""

from __future__ import annotations

import hashlib
import hmac
import os
import secrets
from pathlib import Path

KEY_BYTES = 32
_memo: list[bytes | None] = []


def key_path() -> Path:
    """Where this user's key lives (never under ``$KBPLANNER_CACHE_DIR``, which may be shared)."""
    xdg = os.environ.get("XDG_CACHE_HOME")
    base = Path(xdg) if xdg else Path.home() / ".cache"
    return base / "kbplanner" / "seal.key"


def _key() -> bytes | None:
    if _memo:
        return _memo[0]
    path = key_path()
    key: bytes | None = None
    try:
        key = path.read_bytes()
    except FileNotFoundError:
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
            with os.fdopen(fd, "wb") as fh:
                fh.write(secrets.token_bytes(KEY_BYTES))
        except FileExistsError:  # another command made it meanwhile
            pass
        except OSError:
            key = None
        try:
            key = path.read_bytes()
        except OSError:
            key = None
    except OSError:
        key = None
    if key is not None and len(key) != KEY_BYTES:
        key = None  # half written by another command: no seal this time
    if key is not None:
        _memo.append(key)
    return key


def seal(data: bytes) -> str | None:
    """The seal of ``data`` (hex), or ``None`` when no key can be kept."""
    key = _key()
    return hmac.new(key, data, hashlib.sha256).hexdigest() if key is not None else None


def sealed(data: bytes, mark: str | None) -> bool:
    """Whether ``mark`` is this user's seal of ``data``."""
    if not mark:
        return False
    expected = seal(data)
    return expected is not None and hmac.compare_digest(expected, mark)
