"""One shared thread pool for numpy and Embree work that releases the GIL."""

from __future__ import annotations

import os
import threading
from concurrent.futures import ThreadPoolExecutor

import numpy as np

_pool: ThreadPoolExecutor | None = None
_pool_lock = threading.Lock()


def thread_count() -> int:
    """Threads used for tracing and other parallel work: ``DEFORMRT_THREADS`` if set, else every core."""
    env = os.environ.get("DEFORMRT_THREADS", "")
    if env.strip():
        try:
            return max(1, int(env))
        except ValueError:
            raise ValueError(f"DEFORMRT_THREADS must be a whole number, got {env!r}") from None
    return max(1, os.cpu_count() or 1)


def _get_pool(threads: int) -> ThreadPoolExecutor:
    global _pool
    with _pool_lock:
        if _pool is None or _pool._max_workers != threads:
            if _pool is not None:
                _pool.shutdown(wait=False)
            _pool = ThreadPoolExecutor(max_workers=threads, thread_name_prefix="deformrt")
        return _pool


def map_chunks(fn, n: int, min_chunk: int, threads: int | None = None) -> list:
    """``fn(slice)`` over about ``4 x threads`` slices of ``range(n)`` (none below ``min_chunk``
    items, where a thread hand-off costs more than it saves), in order."""
    threads = thread_count() if threads is None else max(1, int(threads))
    chunks = max(1, min(threads * 4, n // max(1, min_chunk)))
    if chunks == 1 or threads == 1:
        return [fn(slice(0, n))]
    bounds = np.linspace(0, n, chunks + 1).astype(int)
    slices = [slice(a, b) for a, b in zip(bounds[:-1], bounds[1:], strict=True)]
    return list(_get_pool(threads).map(fn, slices))
