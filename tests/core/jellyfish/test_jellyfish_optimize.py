"""core.jellyfish.optimize: reproducible, the same wherever it runs (here, a process pool, a
Dask cluster), stoppable with a usable creature, and its fitness scaling checked by hand."""

import numpy as np
import pytest

from core.jellyfish import (
    Running,
    Search,
    StrokeSpace,
    default_config,
    default_creature,
    fitness,
    optimize,
    reference_scales,
    simulate_cycle,
)
from core.jellyfish.bell import Creature

CFG = default_config(particles=30)  # coarse: these tests are about the search, not the flow


def _same(a, b):
    return (np.array_equal(a.creature.destinations, b.creature.destinations)
            and a.creature.contraction == b.creature.contraction and a.fitness == b.fitness)


def test_the_reference_creature_scores_w_d_minus_w_b_minus_w_e():
    scales = reference_scales(CFG)
    r = simulate_cycle(default_creature(CFG), CFG, scales=scales)
    w_d, w_b, w_e = CFG.weights
    assert r.fitness == pytest.approx(w_d - w_b - w_e, abs=1e-12)
    still = default_creature(CFG)
    lazy = simulate_cycle(Creature(still.controls, still.controls, 0.5), CFG, scales=scales)
    assert lazy.fitness == 0.0  # no stroke: no path, no bending, no energy lost
    assert fitness(0.01, 0.0, 0.0, CFG) == pytest.approx(CFG.weights[0] * 0.01 / CFG.bell.diameter)


def test_stroke_space_round_trips_and_holds_the_default_stroke():
    space = StrokeSpace()
    genes = space.genes(default_creature(CFG), CFG)
    assert ((genes > 0) & (genes < 1)).all()
    back = space.creature(genes, CFG)
    assert np.allclose(back.destinations, default_creature(CFG).destinations, atol=1e-15)
    assert back.contraction == pytest.approx(default_creature(CFG).contraction)
    corner = space.creature(np.zeros(space.dim), CFG)
    a = 0.5 * CFG.bell.diameter
    assert np.allclose(corner.destinations - corner.controls, a * np.array(space.low))
    with pytest.raises(ValueError, match="below its upper"):
        StrokeSpace(contraction=(0.6, 0.2)).creature(genes, CFG)
    with pytest.raises(ValueError, match="unknown method"):
        optimize(CFG, search=Search(method="cma"))
    with pytest.raises(ValueError, match="unknown method"):
        optimize(CFG, method="cma")  # the pipelines' form: optimize(config, method=..., seed=...)
    with pytest.raises(ValueError, match="in the Search"):
        optimize(CFG, method="de", search=Search())
    with pytest.raises(ValueError, match="in the Running"):
        optimize(CFG, running=Running(), workers=1)
    for budget in (0, -3, 2.5):  # 0 used to mean "the default" without a word
        with pytest.raises(ValueError, match="budget"):
            optimize(CFG, search=Search(method="random", budget=budget))


def test_same_seed_same_optimum_in_this_process_and_in_a_process_pool():
    here = optimize(CFG, search=Search(seed=3, population=4, generations=2), running=Running(workers=1))
    again = optimize(CFG, search=Search(seed=3, population=4, generations=2), running=Running(workers=1))
    pool = optimize(CFG, search=Search(seed=3, population=4, generations=2), running=Running(workers=2))
    other = optimize(CFG, search=Search(seed=4, population=4, generations=2), running=Running(workers=1))
    named = optimize(CFG, seed=3, population=4, generations=2, workers=1)  # the older form, by name
    assert (here.backend, pool.backend) == ("serial", "processes") and _same(here, named)
    assert _same(here, again) and _same(here, pool) and not _same(here, other)
    assert here.evaluations == 4 * 3 and [h["evaluations"] for h in here.history] == [4, 8, 12]
    # the best is the best of everything evaluated, and what it reports is what it swims
    assert here.fitness == max(h["best"] for h in here.history)
    replay = simulate_cycle(here.creature, CFG, scales=here.scales)
    assert replay.fitness == pytest.approx(here.fitness, rel=1e-9)


@pytest.mark.parametrize("method", ["de", "random"])
def test_other_methods_spend_their_budget(method):
    # differential evolution spends whole generations (population rounded up to the genes' count)
    r = optimize(CFG, search=Search(method=method, seed=0, population=5, budget=10), running=Running(workers=1))
    assert r.method == method and r.evaluations == 10 and r.stopped == "budget" and np.isfinite(r.fitness)


def test_a_stop_keeps_the_best_creature_so_far_and_progress_reaches_the_caller():
    calls = []
    r = optimize(CFG, search=Search(seed=0, population=4, generations=10),
                 running=Running(workers=2, progress=lambda done, total, best: calls.append((done, total, best)),
                                 stop=lambda: len(calls) >= 6))
    assert r.stopped == "cancelled" and 6 <= r.evaluations < 4 * 11
    assert [c[0] for c in calls] == list(range(1, len(calls) + 1)) and calls[0][1] == 4 * 11
    assert r.fitness == max(c[2] for c in calls)
    assert simulate_cycle(r.creature, CFG, scales=r.scales).fitness == pytest.approx(r.fitness, rel=1e-9)


def test_a_dask_cluster_finds_what_the_local_pool_finds():
    distributed = pytest.importorskip("distributed")
    local = optimize(CFG, search=Search(seed=5, population=4, generations=1), running=Running(workers=2))
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as lc:
        far = optimize(CFG, search=Search(seed=5, population=4, generations=1),
                       running=Running(scheduler=lc.scheduler_address))
    assert far.backend == "dask" and _same(local, far)


def test_an_address_with_no_scheduler_is_refused_in_bounded_time_and_leaves_no_thread():
    """Nothing listening, and a port that takes connections but never answers (which used to hang
    for minutes): a RuntimeError naming the address within the timeout, no IO thread left."""
    pytest.importorskip("distributed")
    import socket
    import threading
    import time

    from core.jellyfish.evaluation import Evaluator

    silent = socket.socket()
    silent.bind(("127.0.0.1", 0))
    silent.listen(4)
    closed = socket.socket()
    closed.bind(("127.0.0.1", 0))  # bound, not listening: refuses
    try:
        for port in (closed.getsockname()[1], silent.getsockname()[1]):
            t0 = time.perf_counter()
            with pytest.raises(RuntimeError, match=f"no Dask scheduler answered at tcp://127.0.0.1:{port}"):
                Evaluator(scheduler=f"tcp://127.0.0.1:{port}", connect_timeout=1.0)
            assert time.perf_counter() - t0 < 5.0
            assert not [t.name for t in threading.enumerate() if "IO loop" in t.name]
    finally:
        silent.close()
        closed.close()


def test_a_search_over_several_cycles_scores_each_creature_over_all_of_them():
    """config.cycles = 2: the fitness reported is the one two cycles in a row give, on scales from
    the default creature's two cycles."""
    from dataclasses import replace

    from core.jellyfish import reference_scales, simulate_cycles

    cfg = replace(CFG, cycles=2)
    r = optimize(cfg, search=Search(seed=1, population=4, generations=1), running=Running(workers=1))
    assert r.scales == reference_scales(CFG, cycles=2)
    replay = simulate_cycles(r.creature, CFG, 2, scales=r.scales)
    assert len(replay.path_per_cycle_m) == 2 and replay.fitness == pytest.approx(r.fitness, rel=1e-9)
    with pytest.raises(ValueError, match="cycles"):
        replace(CFG, cycles=0)


@pytest.mark.parametrize("seed, generations", [(0, 1), (1, 3), (2, 3)])
def test_the_reported_creature_swims_what_was_reported_for_it(seed, generations):
    # the search overwrites its population in place (seed 0: the best parent loses its
    # Boltzmann trial to a worse child); the kept best must not change with it
    r = optimize(CFG, search=Search(seed=seed, population=4, generations=generations), running=Running(workers=1))
    replay = simulate_cycle(r.creature, CFG, scales=r.scales)
    assert replay.fitness == pytest.approx(r.fitness, rel=1e-9)
    assert replay.path_m == pytest.approx(r.cycle.path_m, rel=1e-9)


def test_a_peer_that_answers_garbage_is_refused_with_the_promised_error():
    """An HTTP server at the address (its reply read as a Dask frame header asks for exabytes):
    the RuntimeError that says it is not a Dask scheduler, not a MemoryError."""
    pytest.importorskip("distributed")
    import socket
    import threading

    from core.jellyfish.evaluation import Evaluator

    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(4)
    done = threading.Event()

    def answer():
        server.settimeout(5.0)
        while not done.is_set():
            try:
                conn, _ = server.accept()
            except OSError:
                return
            with conn:
                conn.sendall(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n" * 4)

    thread = threading.Thread(target=answer, daemon=True)
    thread.start()
    port = server.getsockname()[1]
    try:
        with pytest.raises(RuntimeError, match=f"tcp://127.0.0.1:{port}"):
            Evaluator(scheduler=f"tcp://127.0.0.1:{port}", connect_timeout=2.0)
    finally:
        done.set()
        server.close()


def _serve_once(reply: bytes):
    """A peer at a local port that answers every connection with ``reply``; (port, stop)."""
    import socket
    import threading

    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(4)

    def answer():
        while True:
            try:
                conn, _ = server.accept()
            except OSError:
                return
            with conn:
                conn.sendall(reply)
                conn.settimeout(2.0)
                try:
                    conn.recv(1 << 16)
                except OSError:
                    pass

    threading.Thread(target=answer, daemon=True).start()
    return server.getsockname()[1], server.close


def _dask_message(frames: list) -> bytes:
    import struct

    prelude = struct.pack(f"Q{len(frames)}Q", len(frames), *map(len, frames))
    return struct.pack("Q", len(prelude) + sum(map(len, frames))) + prelude + b"".join(frames)


def test_a_peer_sending_a_pickle_never_gets_it_unpickled(tmp_path):
    """A peer that speaks Dask's wire format and sends a pickled object in its handshake and
    reply (Dask's reader would unpickle it: code run in the client before the peer is known to
    be a scheduler): refused, and the pickle never ran."""
    msgpack = pytest.importorskip("msgpack")
    pytest.importorskip("distributed")
    import pickle

    from core.jellyfish.evaluation import Evaluator

    marker = tmp_path / "ran"

    class Payload:
        def __reduce__(self):
            return (open, (str(marker), "w"))

    payload = pickle.dumps(Payload())
    # Dask's own layout for a pickled value: a "__Pickled__" marker in the header naming the frames
    header = msgpack.packb({"type": {"__Pickled__": 1}}, use_bin_type=True)
    sub = msgpack.packb({"pickled-obj": payload, "num-sub-frames": 0}, use_bin_type=True)
    port, stop = _serve_once(_dask_message([header, sub]) * 2)
    try:
        with pytest.raises(RuntimeError, match=f"tcp://127.0.0.1:{port} answered but is not a Dask scheduler"):
            Evaluator(scheduler=f"tcp://127.0.0.1:{port}", connect_timeout=2.0)
    finally:
        stop()
    assert not marker.exists()


def test_a_peer_announcing_a_huge_reply_is_refused_without_allocating_it():
    """A reply that announces 1.5 GB (a peer can make Dask's reader allocate what it claims): refused
    by its announced size, the client's memory peak a few megabytes."""
    import struct
    import tracemalloc

    pytest.importorskip("distributed")
    from core.jellyfish.evaluation import Evaluator

    port, stop = _serve_once(struct.pack("Q", 1_500_000_000) + b"\0" * 4096)
    tracemalloc.start()
    try:
        with pytest.raises(RuntimeError, match="not a Dask scheduler \\(a message of 1500000000 bytes"):
            Evaluator(scheduler=f"tcp://127.0.0.1:{port}", connect_timeout=2.0)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
        stop()
    assert peak < 8 << 20


def test_the_probe_knows_a_real_scheduler_and_a_real_worker_apart():
    """Against Dask itself (an independent speaker of the protocol): a scheduler passes, a worker's
    address (a Dask server, but not a scheduler) is refused."""
    distributed = pytest.importorskip("distributed")
    from core.jellyfish.scheduler_probe import ask_scheduler

    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tcp",
                                  dashboard_address=None) as lc:
        ask_scheduler(lc.scheduler_address, 5.0)
        worker = next(iter(lc.scheduler_info["workers"]))
        with pytest.raises(RuntimeError, match="answered but is not a Dask scheduler"):
            ask_scheduler(worker, 5.0)
    with pytest.raises(ValueError, match="tcp://host:port"):
        ask_scheduler("inproc://x", 1.0)


@pytest.mark.parametrize("goal", ["EFFICIENT", "FASTEST"])
def test_the_search_beats_the_default_stroke_on_its_goal_and_the_fastest_swims_far(goal):
    """Whatever it looks for, the stroke found scores at least the default stroke on that score
    (the default is in the first population); the Farthest goal finds a stroke that swims at least
    1.5 times the default's path over six cycles from rest (measured: 8 times at 60 and 100 particles)."""
    from core.jellyfish import GOAL_WEIGHTS, simulate_cycles

    config = default_config(particles=40, weights=GOAL_WEIGHTS[goal])
    found = optimize(config, search=Search("ga-sa", 0, 6, 2), running=Running(workers=1))
    scales = reference_scales(config)
    default = simulate_cycle(default_creature(config), config, scales=scales)
    assert found.fitness >= default.fitness
    assert simulate_cycle(found.creature, config, scales=scales).fitness == pytest.approx(found.fitness, rel=1e-9)
    if goal == "FASTEST":
        far = simulate_cycles(found.creature, config, 6).path_m
        assert far >= 1.5 * simulate_cycles(default_creature(config), config, 6).path_m


def test_ga_sa_settings_reach_the_search_by_name_and_in_the_search():
    """With no spread about the start and no mutation every creature is the default stroke: the
    best and the mean of every generation are its score, w_d - w_b - w_e; the settings reach
    genetic.ga_sa both as optimize's keywords and as the Search's options."""
    frozen = {"spread": 0.0, "mutation": 0.0}
    by_name = optimize(CFG, seed=0, population=4, generations=1, workers=1, **frozen)
    in_search = optimize(CFG, search=Search(seed=0, population=4, generations=1, options=frozen),
                         running=Running(workers=1))
    w_d, w_b, w_e = CFG.weights
    for r in (by_name, in_search):
        assert r.fitness == pytest.approx(w_d - w_b - w_e, abs=1e-12)
        assert all(h["mean"] == pytest.approx(w_d - w_b - w_e, abs=1e-12) for h in r.history)
    spread = optimize(CFG, seed=0, population=4, generations=1, workers=1)
    assert any(h["mean"] != pytest.approx(w_d - w_b - w_e, abs=1e-6) for h in spread.history)
