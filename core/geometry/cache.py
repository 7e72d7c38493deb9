"""The one way DeformRT keeps results between calls: least recently used entries, within a count
and a byte budget, safe to use from several threads (a background resolve and a frame handler may
share a body). Ray scenes, body facts, what a resolve finds for a garment, topologies, the
jellyfish's pressure factors and the render engine's last scenes are all kept in one of these."""

from __future__ import annotations

import threading
from collections import OrderedDict

import numpy as np


def nbytes(value) -> int:
    """About how much memory arrays hold, inside tuples, lists, dicts and objects' attributes."""
    if isinstance(value, np.ndarray):
        return value.nbytes
    if isinstance(value, (tuple, list)):
        return sum(nbytes(v) for v in value)
    if isinstance(value, dict):
        return sum(nbytes(v) for v in value.values())
    return sum(nbytes(v) for v in vars(value).values()) if hasattr(value, "__dict__") else 0


class Cache:
    """Entries by key, the least recently asked dropped first once there are more than
    ``max_entries`` or they hold more than ``max_bytes`` (what ``put`` is told each holds); an
    entry bigger than the whole budget is not kept. None means no limit of that kind."""

    def __init__(self, max_entries: int | None = None, max_bytes: int | None = None):
        self.max_entries, self.max_bytes = max_entries, max_bytes
        self._entries: OrderedDict = OrderedDict()  # key -> (value, bytes), most recently asked last
        self._held = 0
        self._lock = threading.Lock()

    def get(self, key, default=None):
        with self._lock:
            found = self._entries.pop(key, None)
            if found is None:
                return default
            self._entries[key] = found
            return found[0]

    def __contains__(self, key) -> bool:
        with self._lock:
            return key in self._entries

    def put(self, key, value, size: int = 0, replace: bool = True) -> bool:
        """Keep ``value`` (holding ``size`` bytes) under ``key``; returns whether it is kept. With
        ``replace`` False an entry already there (another thread's) stays."""
        if self.max_bytes is not None and size > self.max_bytes:
            return False
        with self._lock:
            if key in self._entries:
                if not replace:
                    self._entries.move_to_end(key)
                    return True
                self._held -= self._entries.pop(key)[1]
            self._entries[key] = (value, size)
            self._held += size
            while self._entries and ((self.max_entries is not None and len(self._entries) > self.max_entries)
                                     or (self.max_bytes is not None and self._held > self.max_bytes)):
                _, (_, dropped) = self._entries.popitem(last=False)
                self._held -= dropped
            return key in self._entries

    def clear(self) -> None:
        with self._lock:
            self._entries.clear()
            self._held = 0

    def values(self) -> list:
        with self._lock:
            return [v for v, _ in self._entries.values()]

    def items(self) -> list:
        with self._lock:
            return [(k, v) for k, (v, _) in self._entries.items()]

    def held_bytes(self) -> int:
        return self._held

    def __len__(self) -> int:
        return len(self._entries)


__all__ = ["Cache", "nbytes"]
