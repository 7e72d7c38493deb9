"""Evaluate many independent, expensive jobs: in this process, in a pool of processes on
all local cores, or on a Dask cluster for users who outgrow one machine.

Worker processes are spawned, never forked: a fork of Blender (or of any process running
threads) can deadlock. A spawned worker must import this package without running the
add-on's ``__init__`` (which needs bpy, absent from a plain Python); each worker first
registers the package's parents as empty namespace stubs, by source passed to ``exec``
(itself importable anywhere), so any ``core`` function pickles by reference.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import sys
import time
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait

from .scheduler_probe import ask_scheduler

_CORE = __name__.rpartition(".")[0]  # "core", or e.g. "bl_ext.user_default.deformrt.core"
_BOOTSTRAP = f"""
import os, sys, types
_parts = {_CORE.split(".")!r}
_core_dir = {os.path.dirname(os.path.abspath(__file__))!r}
for _k in range(1, len(_parts)):
    _name = ".".join(_parts[:_k])
    if _name not in sys.modules:
        _stub = types.ModuleType(_name)
        # only the package holding core needs a real path; higher ones hold stubs
        _stub.__path__ = [os.path.dirname(_core_dir)] if _k == len(_parts) - 1 else []
        sys.modules[_name] = _stub
if len(_parts) == 1 and os.path.dirname(_core_dir) not in sys.path:
    sys.path.insert(0, os.path.dirname(_core_dir))
"""


class Cancelled(Exception):
    """The caller asked to stop; results finished before then are in ``done``."""

    def __init__(self, done):
        super().__init__("cancelled")
        self.done = done


def worker_count(workers=None) -> int:
    """``workers`` if given, else every local core."""
    if workers is None:
        return max(1, os.cpu_count() or 1)
    workers = int(workers)
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    return workers


def _python():
    """The interpreter to spawn: inside Blender sys.executable is the Blender binary in older
    releases; the bundled Python then sits in sys.prefix/bin."""
    exe = sys.executable
    if os.path.basename(exe).lower().startswith("python"):
        return exe
    for name in ("python3.11", "python3", "python", "python.exe"):
        candidate = os.path.join(sys.prefix, "bin", name)
        if os.path.exists(candidate):
            return candidate
    return exe


@contextlib.contextmanager
def _main_hidden():
    """A spawned worker runs the parent's main script again unless it is guarded by
    ``if __name__ == "__main__"``, which scripts for ``blender --python`` seldom are; jobs
    here only need core, so the workers are started without knowing the main script."""
    main = sys.modules.get("__main__")
    saved = {k: main.__dict__[k] for k in ("__file__", "__spec__") if main is not None and k in main.__dict__}
    try:
        for k in saved:
            if k == "__spec__":
                main.__spec__ = None
            else:
                del main.__dict__[k]
        yield
    finally:
        if main is not None:
            main.__dict__.update(saved)


class Evaluator:
    """``map(fn, items)`` in order. ``workers=1`` runs in this process; more (default: every
    core) use a process pool kept for the evaluator's life; ``scheduler="tcp://host:port"``
    (or a ``distributed.Client``) sends the jobs to a Dask cluster instead."""

    def __init__(self, workers=None, scheduler=None, connect_timeout: float = 10.0):
        self.workers = worker_count(workers)
        self._pool = None
        self._client = None
        self._own_client = False
        if scheduler is not None:
            try:
                from distributed import Client
            except ImportError as err:
                raise RuntimeError("a Dask scheduler needs the 'distributed' package: pip install distributed") from err
            if isinstance(scheduler, Client):
                self._client = scheduler
            else:
                ask_scheduler(str(scheduler), connect_timeout)
                self._client, self._own_client = Client(scheduler, timeout=connect_timeout), True
            # jobs name core functions by module, so workers must see this package's files (a
            # LocalCluster, or machines sharing its storage); the stubs make its name importable
            self._client.run(exec, _BOOTSTRAP)

    @property
    def backend(self) -> str:
        return "dask" if self._client is not None else ("serial" if self.workers == 1 else "processes")

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def close(self):
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None
        if self._client is not None and self._own_client:
            self._client.close()
        self._client = None

    def map(self, fn, items, on_done=None, stop=None) -> list:
        """Results of ``fn(item)`` in order. ``on_done(k, result)`` is called as each finishes
        (in this process); ``stop()`` is polled meanwhile and, when true, drops what has not
        started and raises Cancelled with the finished results by index."""
        items = list(items)
        stop = stop or (lambda: False)
        if self._client is not None:
            return self._map_dask(fn, items, on_done, stop)
        if self.workers == 1 or len(items) <= 1:
            out = {}
            for k, item in enumerate(items):
                if stop():
                    raise Cancelled(out)
                out[k] = fn(item)
                if on_done:
                    on_done(k, out[k])
            return [out[k] for k in range(len(items))]
        return self._map_pool(fn, items, on_done, stop)

    def _pool_executor(self):
        if self._pool is None:
            ctx = multiprocessing.get_context("spawn")
            ctx.set_executable(_python())
            self._pool = ProcessPoolExecutor(self.workers, mp_context=ctx, initializer=exec, initargs=(_BOOTSTRAP,))
        return self._pool

    def _map_pool(self, fn, items, on_done, stop):
        pool = self._pool_executor()
        with _main_hidden():  # the pool spawns its workers inside submit()
            futures = {pool.submit(fn, item): k for k, item in enumerate(items)}
        return self._collect(futures, on_done, stop)

    def _map_dask(self, fn, items, on_done, stop):
        futures = self._client.map(fn, items, pure=False)
        keyed = {f: k for k, f in enumerate(futures)}
        return self._collect(keyed, on_done, stop, dask=True)

    def _collect(self, futures, on_done, stop, dask=False):
        out, pending = {}, set(futures)
        while pending:
            if stop():
                for f in pending:
                    f.cancel()
                raise Cancelled(out)
            if dask:
                done = [f for f in pending if f.done()]
                if not done:
                    time.sleep(0.05)
            else:
                done, _ = wait(pending, timeout=0.2, return_when=FIRST_COMPLETED)
            for f in done:
                k = futures[f]
                out[k] = f.result()
                pending.discard(f)
                if on_done:
                    on_done(k, out[k])
        return [out[k] for k in range(len(futures))]
