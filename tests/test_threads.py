"""Heavy calls release the GIL and give the same results from several threads at once."""

import threading
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np

import softshadows as ss
from softshadows import scenes


def test_ray_traced_releases_the_gil():
    setup = scenes.columns(width=160, height=160)
    gb = ss.gbuffer(setup.scene, setup.camera)
    setup.scene.native()  # build the BVH here, not in the timed call
    done = threading.Event()
    span = []

    def work():
        start = time.perf_counter()
        ss.ray_traced(setup.scene, setup.light, gb, samples=1024)
        span.append(time.perf_counter() - start)
        done.set()

    stamps = [time.perf_counter()]
    worker = threading.Thread(target=work)
    worker.start()
    while not done.is_set():  # spins freely only while the worker has released the GIL
        stamps.append(time.perf_counter())
    worker.join()
    assert span[0] > 0.05, "the call is too short to tell"
    # Holding the GIL for the whole Rust call would stall this loop for about that long
    # (counting iterations cannot tell: the loop also runs before and after the call).
    assert np.max(np.diff(stamps)) < 0.5 * span[0]


def test_concurrent_calls_equal_serial_calls():
    setup = scenes.fence(width=64, height=64)
    gb = ss.gbuffer(setup.scene, setup.camera)
    kwargs = [dict(samples=32, seed=s, rotate="per_receiver") for s in range(8)]
    serial = [ss.ray_traced(setup.scene, setup.light, gb, **k) for k in kwargs]
    with ThreadPoolExecutor(8) as pool:
        parallel = list(pool.map(lambda k: ss.ray_traced(setup.scene, setup.light, gb, **k), kwargs))
    for a, b in zip(serial, parallel):
        np.testing.assert_array_equal(a, b)
    assert not np.array_equal(serial[0], serial[1])


def test_results_do_not_depend_on_the_thread_count():
    setup = scenes.columns(width=64, height=64)
    gb = ss.gbuffer(setup.scene, setup.camera)
    samples = setup.light.samples(32, seed=2)
    calls = {
        "ray_traced": lambda: ss.ray_traced(setup.scene, setup.light, gb, samples=32, rotate="per_receiver"),
        "alias_free": lambda: ss.alias_free(setup.scene, setup.light, gb, samples=samples),
        "dcs": lambda: ss.dcs(setup.scene, setup.light, gb, samples=samples),
        "vwss": lambda: ss.vwss(setup.scene, setup.light, gb, samples=8),
        "backprojection": lambda: ss.backprojection(setup.scene, setup.light, gb, resolution=256, budget=6),
    }
    try:
        results = {}
        for threads in (1, 3):
            ss.set_num_threads(threads)
            assert ss.num_threads() == threads
            results[threads] = {name: call() for name, call in calls.items()}
    finally:
        ss.set_num_threads(None)
    for name in calls:
        np.testing.assert_array_equal(results[1][name], results[3][name], err_msg=name)


def _child_visibility(queue):
    setup = scenes.columns(width=32, height=32)
    gb = ss.gbuffer(setup.scene, setup.camera)
    queue.put(ss.ray_traced(setup.scene, setup.light, gb, samples=16))


def test_forked_children_get_their_own_pool():
    import multiprocessing

    setup = scenes.columns(width=32, height=32)
    gb = ss.gbuffer(setup.scene, setup.camera)
    parent = ss.ray_traced(setup.scene, setup.light, gb, samples=16)  # the parent's pool is running
    context = multiprocessing.get_context("fork")
    queue = context.Queue()
    child = context.Process(target=_child_visibility, args=(queue,))
    child.start()
    try:
        result = queue.get(timeout=60)  # a child waiting on the parent's threads would hang here
    finally:
        child.join(timeout=10)
        if child.is_alive():
            child.kill()
    np.testing.assert_array_equal(result, parent)
