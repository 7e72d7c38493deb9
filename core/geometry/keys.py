"""Content keys for what is kept between calls (a garment's facts, a mesh's topology)."""

from __future__ import annotations

import hashlib

import numpy as np


def digest(*arrays) -> bytes:
    """A key for the content of these arrays (dtype, shape and bytes)."""
    h = hashlib.sha1(usedforsecurity=False)  # the fastest here (hardware SHA): twice blake2b; a key, not a seal
    for a in arrays:
        a = np.ascontiguousarray(a)
        h.update(str((a.dtype, a.shape)).encode())
        h.update(a.data)
    return h.digest()


__all__ = ["digest"]
