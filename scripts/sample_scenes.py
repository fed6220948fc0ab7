#!/usr/bin/env python3
"""Run every sample scene and keep docs/sample-scenes.md's table true.

    python3 scripts/sample_scenes.py            # run them all, rewrite the table
    python3 scripts/sample_scenes.py --check    # run them all, exit 1 if the table drifted
    python3 scripts/sample_scenes.py stack coil # only these (with or without --check)

Each scene runs as a user would (`tetsim run scenes/NAME.toml --deterministic --no-pictures`)
with the release binary (TETSIM_BIN, default target/release/tetsim; build it first). The
numbers come from the run's own steps.csv, read here with the csv module, not from tetsim's
summary. Every column but the wall time is deterministic (tetsim's results are the same bits
for any thread count), so --check compares them exactly; the wall time is informative.
Standard library only.
"""

import argparse
import csv
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DOC = ROOT / "docs" / "sample-scenes.md"
BEGIN = "<!-- sample-scenes:begin -->"
END = "<!-- sample-scenes:end -->"
COLUMNS = [
    "scene",
    "frames",
    "Newton",
    "most Newton (frame)",
    "retried frames",
    "not converged",
    "min J",
    "min gap [m]",
]


def run(binary, scene, out):
    started = time.monotonic()
    done = subprocess.run(
        [binary, "run", str(scene), "--out", str(out), "--deterministic", "--no-pictures", "-q"],
        capture_output=True,
        text=True,
    )
    wall = time.monotonic() - started
    if done.returncode != 0:
        sys.exit(f"{scene.name}: exit {done.returncode}\n{done.stderr}")
    return wall


def summarize(name, steps):
    with open(steps, newline="") as f:
        rows = list(csv.DictReader(f))[1:]  # frame 0 is the initial state
    newton = [int(r["newton_iterations"]) for r in rows]
    substeps = [int(r["substeps"]) for r in rows]
    most = max(range(len(rows)), key=lambda i: (newton[i], -i))
    gaps = [float(r["min_distance"]) for r in rows if r.get("min_distance")]
    return {
        "scene": name,
        "frames": str(len(rows)),
        "Newton": str(sum(newton)),
        "most Newton (frame)": f"{newton[most]} ({rows[most]['frame']})",
        # A retried frame used more substeps than the scene's least (its step was cut).
        "retried frames": str(sum(1 for s in substeps if s > min(substeps))),
        "not converged": str(sum(1 for r in rows if r["converged"] != "true")),
        "min J": f"{min(float(r['min_J']) for r in rows):.3f}",
        "min gap [m]": f"{min(gaps):.1e}" if gaps else "-",
    }


def table(rows, walls):
    lines = ["| " + " | ".join(COLUMNS + ["wall [s]"]) + " |"]
    lines.append("|" + "---|" * (len(COLUMNS) + 1))
    for r in rows:
        cells = [r[c] for c in COLUMNS] + [f"{walls[r['scene']]:.1f}"]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def parse_table(text):
    body = text.split(BEGIN, 1)[1].split(END, 1)[0]
    rows = {}
    for line in body.strip().splitlines()[2:]:
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        rows[cells[0]] = dict(zip(COLUMNS, cells))
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scenes", nargs="*", help="scene names (default: every scenes/*.toml)")
    ap.add_argument("--check", action="store_true", help="compare with the doc; change nothing")
    args = ap.parse_args()
    binary = os.environ.get("TETSIM_BIN", str(ROOT / "target" / "release" / "tetsim"))
    names = args.scenes or sorted(p.stem for p in (ROOT / "scenes").glob("*.toml"))
    text = DOC.read_text()
    documented = parse_table(text)
    rows, walls = [], {}
    with tempfile.TemporaryDirectory() as tmp:
        for name in names:
            out = Path(tmp) / name
            walls[name] = run(binary, ROOT / "scenes" / f"{name}.toml", out)
            rows.append(summarize(name, out / "steps.csv"))
            print(f"{name}: {rows[-1]}  ({walls[name]:.1f} s)", flush=True)
    if args.check:
        drift = []
        for r in rows:
            doc = documented.get(r["scene"])
            if doc is None:
                drift.append(f"{r['scene']}: not in {DOC.name}")
                continue
            drift += [
                f"{r['scene']}: {c} documented {doc.get(c)}, measured {r[c]}"
                for c in COLUMNS
                if doc.get(c) != r[c]
            ]
        missing = sorted(set(documented) - {p.stem for p in (ROOT / "scenes").glob("*.toml")})
        drift += [f"{m}: documented, but scenes/{m}.toml is gone" for m in missing]
        print("\n".join(drift) if drift else f"{DOC.name}: every figure as measured")
        sys.exit(1 if drift else 0)
    # Rewrite: the scenes run now replace their rows; others keep theirs.
    merged = {name: dict(r, **{"wall [s]": None}) for name, r in documented.items()}
    old_walls = {}
    for line in text.split(BEGIN, 1)[1].split(END, 1)[0].strip().splitlines()[2:]:
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        old_walls[cells[0]] = float(cells[-1])
    for r in rows:
        merged[r["scene"]] = r
    all_walls = {**old_walls, **walls}
    ordered = [merged[n] for n in sorted(merged) if (ROOT / "scenes" / f"{n}.toml").exists()]
    head, rest = text.split(BEGIN, 1)
    tail = rest.split(END, 1)[1]
    DOC.write_text(f"{head}{BEGIN}\n{table(ordered, all_walls)}\n{END}{tail}")
    print(f"wrote {DOC}")


if __name__ == "__main__":
    main()
