"""Ctrl-C stops a long run between frames, with the files so far valid and the manifest
saying it stopped; the GIL is released while stepping, so other threads run meanwhile."""

import json
import os
import signal
import threading
import time

import pytest

import tetsim

from test_simulation import box_scene


@pytest.mark.skipif(os.name != "posix", reason="sends SIGINT to itself")
def test_ctrl_c_interrupts_a_long_run(tmp_path):
    sim = tetsim.Simulation(tetsim.Scene.from_dict(box_scene(frames=100000)))
    timer = threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    started = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        sim.run(tmp_path)
    timer.cancel()
    assert time.monotonic() - started < 60
    assert 0 < sim.frame < sim.frames
    manifest = json.loads((tmp_path / "manifest.json").read_text())
    assert manifest["status"] == f"stopped: interrupted after frame {sim.frame}"
    assert (tmp_path / f"frame_{sim.frame:04d}.vtu").exists()
    assert len((tmp_path / "steps.csv").read_text().splitlines()) == sim.frame + 2


def test_the_gil_is_released_while_stepping():
    # A Python thread counts while the main thread steps: it can only count if the GIL is free.
    sim = tetsim.Simulation(tetsim.Scene.from_dict(box_scene(cells=(24, 8, 8), frames=2, substeps=4)))
    ticks = []
    running = threading.Event()
    running.set()

    def count():
        while running.is_set():
            ticks.append(1)
            time.sleep(0.001)

    counter = threading.Thread(target=count)
    counter.start()
    try:
        time.sleep(0.05)
        before = len(ticks)
        started = time.monotonic()
        sim.step()  # one call, many substeps: tens of milliseconds inside Rust
        elapsed = time.monotonic() - started
        during = len(ticks) - before
    finally:
        running.clear()
        counter.join()
    # Held, the GIL would let the counter tick once or twice at most; released, it ticks about
    # once a millisecond.
    assert elapsed > 0.02 and during >= 5, (elapsed, during)
