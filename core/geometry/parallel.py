"""One shared thread pool for numpy and Embree work that releases the GIL."""

from __future__ import annotations

import os
import threading
from concurrent.futures import ThreadPoolExecutor

import numpy as np

_pool: ThreadPoolExecutor | None = None
_pool_lock = threading.Lock()
# os.cpu_count() asks the system each call (34 us here, 236 calls in a played frame)
_CORES = max(1, os.cpu_count() or 1)


def thread_count() -> int:
    """Threads used for tracing and other parallel work: ``DEFORMRT_THREADS`` if set, else every core."""
    env = os.environ.get("DEFORMRT_THREADS", "")
    if env.strip():
        try:
            return max(1, int(env))
        except ValueError:
            raise ValueError(f"DEFORMRT_THREADS must be a whole number, got {env!r}") from None
    return _CORES


# A k-d tree query with workers=-1 starts and joins its own threads each call (about 1 ms a call in
# Blender, 14 ms a playback frame over the small queries a resolve makes): below this many points
# one thread answers sooner.
MIN_POINTS_PER_WORKER = 8192


def tree_workers(n_points: int) -> int:
    """The ``workers`` for a scipy k-d tree query of ``n_points`` points: every core for a big
    query, the calling thread for a small one (the answers are the same)."""
    return -1 if n_points >= 2 * MIN_POINTS_PER_WORKER else 1


def _get_pool(threads: int) -> ThreadPoolExecutor:
    global _pool
    with _pool_lock:
        if _pool is None or _pool._max_workers != threads:
            if _pool is not None:
                _pool.shutdown(wait=False)
            _pool = ThreadPoolExecutor(max_workers=threads, thread_name_prefix="deformrt")
        return _pool


def shutdown() -> None:
    """Stop the shared pool's threads (they start again on the next parallel call): an add-on
    that is switched off leaves none running."""
    global _pool
    with _pool_lock:
        if _pool is not None:
            _pool.shutdown(wait=True, cancel_futures=True)
            _pool = None


def map_chunks(fn, n: int, min_chunk: int, threads: int | None = None, block: int | None = None) -> list:
    """``fn(slice)`` over about ``4 x threads`` slices of ``range(n)`` (none below ``min_chunk``
    items, where a thread hand-off costs more than it saves), in order. With ``block``, each
    thread walks its slice in pieces of at most ``block`` items, one call each (all the calls'
    results in order): numpy work whose temporaries of a piece stay in the core's cache runs
    faster than over the whole slice at once."""
    threads = thread_count() if threads is None else max(1, int(threads))
    chunks = max(1, min(threads * 4, n // max(1, min_chunk)))
    if block:
        step = max(1, int(block))

        def call(sl):
            return [fn(slice(a, min(a + step, sl.stop))) for a in range(sl.start, sl.stop, step)] or [fn(sl)]
    else:
        def call(sl):
            return [fn(sl)]
    if chunks == 1 or threads == 1:
        return call(slice(0, n))
    bounds = np.linspace(0, n, chunks + 1).astype(int)
    slices = [slice(a, b) for a, b in zip(bounds[:-1], bounds[1:], strict=True)]
    return [r for part in _get_pool(threads).map(call, slices) for r in part]
