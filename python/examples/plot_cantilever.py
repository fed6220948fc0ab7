# %% [markdown]
# # A cantilever from Python
#
# Step `scenes/cantilever.toml` frame by frame, follow its tip, then sweep Young's modulus with
# `Scene.from_dict` and compare the sag. Plots with matplotlib when it is installed (else prints
# the numbers). Run it as a script (`python python/examples/plot_cantilever.py`) or cell by cell
# in an editor that reads `# %%` cells.

# %%
import argparse
import pathlib

import numpy as np

import tetsim

ROOT = pathlib.Path(__file__).resolve().parents[2]
parser = argparse.ArgumentParser(description=__doc__)
parser.add_argument("--frames", type=int, default=90, help="frames of the run (default 90)")
parser.add_argument("--out", type=pathlib.Path, default=pathlib.Path("out/python_example"))
args, _ = parser.parse_known_args()
args.out.mkdir(parents=True, exist_ok=True)

# %% One run, stepped from Python
values = tetsim.Scene.load(ROOT / "scenes" / "cantilever.toml").to_dict()
values["solver"]["frames"] = args.frames
sim = tetsim.Simulation(tetsim.Scene.from_dict(values))
rest = sim.rest_positions
tip = np.flatnonzero(np.isclose(rest[:, 0], rest[:, 0].max()))  # the free end's face

time, sag, elastic, kinetic = [0.0], [0.0], [], []
while not sim.is_finished:
    stats = sim.step()  # the frame's steps.csv columns
    time.append(stats["time"])
    sag.append(float((sim.positions[tip, 1] - rest[tip, 1]).mean()))
    elastic.append(stats["elastic_energy"])
    kinetic.append(stats["kinetic_energy"])
print(f"{sim.frame} frames, tip sag at the end {sag[-1]:.4f} m")

# %% A sweep: the sag at rest (quasistatic) for three stiffnesses
sweep = []
for youngs_modulus in (1e6, 2e6, 4e6):
    v = tetsim.Scene.load(ROOT / "scenes" / "cantilever.toml").to_dict()
    v["material"]["youngs_modulus"] = youngs_modulus
    v["solver"].update(integrator="quasistatic", frames=4)
    s = tetsim.Simulation(tetsim.Scene.from_dict(v))
    s.run(args.out / f"E{youngs_modulus:.0e}")  # frames, steps.csv, manifest.json
    sweep.append((youngs_modulus, float((s.positions[tip, 1] - rest[tip, 1]).mean())))
for e, d in sweep:
    print(f"E = {e:.0e} Pa: static tip sag {d:.4f} m")

# %% Plot
try:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError:
    print("matplotlib is not installed: pip install matplotlib for the plot")
else:
    fig, (a, b, c) = plt.subplots(1, 3, figsize=(13, 3.6))
    a.plot(time, sag)
    a.set(xlabel="time (s)", ylabel="tip displacement y (m)", title="tip")
    b.plot(time[1:], elastic, label="elastic")
    b.plot(time[1:], kinetic, label="kinetic")
    b.set(xlabel="time (s)", ylabel="energy (J)", title="energies")
    b.legend()
    c.loglog([e for e, _ in sweep], [-d for _, d in sweep], "o-")
    c.set(xlabel="Young's modulus (Pa)", ylabel="static sag (m)", title="sweep")
    fig.tight_layout()
    fig.savefig(args.out / "cantilever.png", dpi=100)
    print(f"wrote {args.out / 'cantilever.png'}")
