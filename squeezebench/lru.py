"""What a process built lately, kept by a key of the caller's choosing.

`functools.lru_cache` keys on the call's arguments; the scene loader and the plate model
key on something narrower (a scene's file name and text, not the folder a study task
wrote it into; a hash of a plate's geometry and materials), so they keep their results
here instead. Threads may share it (`reproduce` on one worker loads scenes on the
campaign's thread and the study's): a value is built outside the lock, so a slow build
holds no other thread up, and two threads building the same key at once keep the first.
"""

from __future__ import annotations

import collections
import threading
from typing import Callable, Generic, Hashable, TypeVar

V = TypeVar("V")


class RecentlyUsed(Generic[V]):
    """At most `size` values, the least recently used going first."""

    def __init__(self, size: int) -> None:
        if size < 1:
            raise ValueError(f"size must be at least 1, got {size!r}")
        self.size = size
        self._values: collections.OrderedDict[Hashable, V] = collections.OrderedDict()
        self._lock = threading.Lock()

    def get(self, key: Hashable, build: Callable[[], V]) -> V:
        """The value kept under `key`, else `build()`, kept (a build that raises keeps nothing)."""
        with self._lock:
            if key in self._values:
                self._values.move_to_end(key)
                return self._values[key]
        value = build()
        with self._lock:
            value = self._values.setdefault(key, value)
            self._values.move_to_end(key)
            while len(self._values) > self.size:
                self._values.popitem(last=False)
        return value

    def __len__(self) -> int:
        return len(self._values)

    def clear(self) -> None:
        with self._lock:
            self._values.clear()
