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
    """At most `size` values, the least recently used going first; with `max_bytes`, also
    no more than that many bytes as `weigh(value)` counts them (the newest value is kept
    whatever it weighs)."""

    def __init__(self, size: int, max_bytes: int | None = None, weigh: Callable[[V], int] | None = None) -> None:
        if size < 1:
            raise ValueError(f"size must be at least 1, got {size!r}")
        if (max_bytes is None) != (weigh is None):
            raise ValueError("max_bytes and weigh go together")
        self.size = size
        self.max_bytes = max_bytes
        self._weigh = weigh
        self._values: collections.OrderedDict[Hashable, V] = collections.OrderedDict()
        self._bytes: dict[Hashable, int] = {}
        self._lock = threading.Lock()

    def get(self, key: Hashable, build: Callable[[], V]) -> V:
        """The value kept under `key`, else `build()`, kept (a build that raises keeps nothing)."""
        with self._lock:
            if key in self._values:
                self._values.move_to_end(key)
                return self._values[key]
        value = build()
        with self._lock:
            if key not in self._values and self._weigh is not None:
                self._bytes[key] = self._weigh(value)
            value = self._values.setdefault(key, value)
            self._values.move_to_end(key)
            while len(self._values) > self.size or (
                    len(self._values) > 1 and self.max_bytes is not None and self.bytes > self.max_bytes):
                self._bytes.pop(self._values.popitem(last=False)[0], None)
        return value

    @property
    def bytes(self) -> int:
        """What the values kept weigh (0 without `weigh`)."""
        return sum(self._bytes.values())

    def __len__(self) -> int:
        return len(self._values)

    def clear(self) -> None:
        with self._lock:
            self._values.clear()
            self._bytes.clear()
