"""Ctrl-C stops a long run, inside the frame being computed, with the files so far valid and the manifest
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
    assert manifest["status"] == "interrupted" and manifest["frame"] == sim.frame
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


@pytest.mark.skipif(os.name != "posix", reason="sends SIGINT to itself")
def test_ctrl_c_stops_a_long_step_inside_it():
    # A cube dropped at 1,000 m/s spends over a minute in its first frame (every retry capped);
    # Ctrl-C ends that frame within a Newton iteration and leaves the state at frame 0.
    scene = {
        "gravity": [0.0, -9.81, 0.0],
        "mesh": {"generator": {"box": {"min": [-0.5, 0.5, -0.5], "max": [0.5, 1.5, 0.5], "cells": [3, 3, 3]}}},
        "material": {"youngs_modulus": 1e5, "poisson_ratio": 0.3},
        "initial": {"velocity": [0.0, -1000.0, 0.0]},
        "obstacle": [{"plane": {"point": [0, 0, 0], "normal": [0, 1, 0]}}],
        "solver": {"dt": 0.01, "frames": 5},
    }
    sim = tetsim.Simulation(tetsim.Scene.from_dict(scene))
    before = sim.positions.copy()
    timer = threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    started = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        sim.step()
    timer.cancel()
    assert time.monotonic() - started < 30
    assert sim.frame == 0
    assert (sim.positions == before).all()
