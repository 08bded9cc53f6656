"""What takes seconds to compute, kept on disk for the next process that asks for it.

One folder, `cache_dir()`: $SQUEEZEBENCH_CACHE, default $XDG_CACHE_HOME/squeezebench, else
~/.cache/squeezebench; `off` keeps nothing. A plan keeps its measurements in `plan/`
(`protocols.plan_cache`), the plate model its finite-element solves in `plates/`
(`plates.plate_modes`, an `ArrayStore`). Every entry is keyed by a digest of all that
decides it, the code's own source included (`source_fingerprint`), so a changed input or
a changed model is a new key and nothing stale is read.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import importlib
import os
import tempfile
import time
import zipfile
from pathlib import Path
from typing import Callable

import numpy as np

CACHE_VARIABLE = "SQUEEZEBENCH_CACHE"


def cache_dir() -> Path | None:
    """Where results are kept, or None when $SQUEEZEBENCH_CACHE is `off`."""
    text = os.environ.get(CACHE_VARIABLE, "").strip()
    if text.lower() == "off":
        return None
    if text:
        return Path(text).expanduser()
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "squeezebench"


@functools.cache
def source_fingerprint(packages: tuple[str, ...]) -> str:
    """SHA-256 of the Python source of `packages`, file by file (names and bytes)."""
    digest = hashlib.sha256()
    for package in packages:
        for folder in importlib.import_module(package).__path__:
            for path in sorted(Path(folder).glob("*.py")):
                digest.update(f"{package}/{path.name}\0".encode())
                digest.update(path.read_bytes())
    return digest.hexdigest()


def arrays_digest(arrays: dict[str, np.ndarray]) -> str:
    """SHA-256 of named arrays: each name, dtype, shape and bytes, in name order."""
    digest = hashlib.sha256()
    for name in sorted(arrays):
        array = np.ascontiguousarray(arrays[name])
        digest.update(f"{name}\0{array.dtype.str}\0{array.shape}\0".encode())
        digest.update(array.tobytes())
    return digest.hexdigest()


#: A temporary file older than this is a write a killed process left (a write takes well under a second).
ABANDONED_WRITE_S = 600.0


class ArrayStore:
    """Named arrays in `folder` (None: kept nowhere), one .npz file per key (a hex digest of
    all that decides them). A file is written whole under a temporary name and renamed onto
    its own, so processes building the same key at once leave one complete file; it is read
    back only if it names the key asked for and its arrays still give the digest stored
    beside them: a truncated, corrupt or foreign file is built again and overwritten, never
    trusted. The folder stays under `bytes_limit`, the least recently used files going first;
    an unwritable folder keeps nothing and says nothing (the value is still returned)."""

    def __init__(self, folder: Path | None, bytes_limit: int) -> None:
        self.folder = folder
        self.bytes_limit = bytes_limit

    def path(self, key: str) -> Path:
        return self.folder / f"{key}.npz"

    def get(self, key: str, build: Callable[[], dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
        """The arrays kept under `key`, else `build()`'s, kept."""
        if self.folder is None:
            return build()
        kept = self.read(key)
        if kept is not None:
            return kept
        arrays = build()
        self._write(key, arrays)
        return arrays

    def read(self, key: str) -> dict[str, np.ndarray] | None:
        """The arrays kept under `key` if their file is whole and theirs, else None."""
        path = self.path(key)
        try:
            with np.load(path, allow_pickle=False) as data:
                arrays = {name: data[name] for name in data.files if not name.startswith("_")}
                if str(data["_key"]) != key or str(data["_digest"]) != arrays_digest(arrays):
                    return None
            _touch(path)
        except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile):
            return None
        return arrays

    def _write(self, key: str, arrays: dict[str, np.ndarray]) -> None:
        temporary = None
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
            handle, temporary = tempfile.mkstemp(dir=self.folder, prefix=f".{key[:16]}-", suffix=".tmp")
            with os.fdopen(handle, "wb") as file:
                np.savez(file, _key=np.array(key), _digest=np.array(arrays_digest(arrays)), **arrays)
            _touch(temporary)
            os.replace(temporary, self.path(key))
        except OSError:
            if temporary is not None:
                with contextlib.suppress(OSError):
                    os.unlink(temporary)
            return
        self._trim()

    def _trim(self) -> None:
        """Remove the least recently used files while the folder exceeds its limit, and
        writes a killed process abandoned."""
        entries = []
        for path in self.folder.iterdir():
            with contextlib.suppress(OSError):
                status = path.stat()
                if path.suffix == ".tmp":
                    if status.st_mtime < time.time() - ABANDONED_WRITE_S:
                        path.unlink()
                elif path.suffix == ".npz":
                    entries.append((status.st_mtime, status.st_size, path))
        total = sum(size for _, size, _ in entries)
        for _, size, path in sorted(entries):
            if total <= self.bytes_limit:
                break
            with contextlib.suppress(OSError):
                path.unlink()
            total -= size


def _touch(path: Path | str) -> None:
    """Mark a file used now, to the nanosecond (the last to go when the folder is trimmed;
    the file system's own clock ticks in milliseconds and would tie files used in a row)."""
    now_ns = time.time_ns()
    os.utime(path, ns=(now_ns, now_ns))
