"""The default scene's beam made 100 times stiffer (E = 100 MPa, about 3 Hz), undamped, under each time
scheme: its tip's vertical displacement over 3 s, drawn into docs/time-schemes.svg, and a table of what each scheme kept and cost.

usage: python3 tools/plot_time_schemes.py [TETSIM]   (default: target/release/tetsim)
Runs tetsim three times (a minute or two in all); reads probes.csv and steps.csv with the csv
module only.
"""
import csv, os, subprocess, sys, tempfile

TETSIM = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else "target/release/tetsim")
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCHEMES = [("backward-euler", "#d62728"), ("bdf2", "#1f77b4"), ("newmark", "#2ca02c")]
SCENE = """gravity = [0.0, -9.81, 0.0]
[mesh]
generator = {{ box = {{ min = [0.0, 0.0, 0.0], max = [4.0, 1.0, 1.0], cells = [20, 5, 5] }} }}
[material]
model = "neo-hookean"
youngs_modulus = 1.0e8
poisson_ratio = 0.3
density = 1000.0
[[fixed]]
region = {{ physical = "xmin" }}
[[probe]]
name = "tip"
point = [4.0, 0.5, 0.5]
[solver]
integrator = "{scheme}"
dt = 0.033333333333333333
frames = 90
newton_tolerance = 1e-6
"""


def run(scheme, work):
    scene = os.path.join(work, scheme + ".toml")
    open(scene, "w").write(SCENE.format(scheme=scheme))
    out = os.path.join(work, scheme)
    subprocess.run([TETSIM, "run", scene, "--out", out, "--no-pictures", "-q"], check=True)
    probes = list(csv.DictReader(open(os.path.join(out, "probes.csv"))))
    steps = [r for r in csv.DictReader(open(os.path.join(out, "steps.csv"))) if r["frame"] != "0"]
    t = [float(r["time"]) for r in probes]
    y = [float(r["tip_y"]) for r in probes]
    newton = sum(int(r["newton_iterations"]) for r in steps) / len(steps)
    cg = sum(int(r["cg_iterations"]) for r in steps) / len(steps)
    dissipated = sum(float(r["numerical_dissipation"]) for r in steps)
    return t, y, newton, cg, dissipated


def swing(t, y, lo, hi):
    part = [v for s, v in zip(t, y) if lo <= s <= hi]
    return max(part) - min(part)


def svg(curves):
    w, h, m = 760, 360, 50
    tmax = max(max(c[0]) for c in curves.values())
    ys = [v for c in curves.values() for v in c[1]]
    ylo, yhi = min(ys), max(ys)
    px = lambda s: m + (w - 2 * m) * s / tmax
    py = lambda v: h - m - (h - 2 * m) * (v - ylo) / (yhi - ylo)
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" font-size="13">',
           f'<rect width="{w}" height="{h}" fill="white"/>',
           f'<line x1="{m}" y1="{h - m}" x2="{w - m}" y2="{h - m}" stroke="black"/>',
           f'<line x1="{m}" y1="{m}" x2="{m}" y2="{h - m}" stroke="black"/>']
    for k in range(7):
        s = tmax * k / 6
        out.append(f'<text x="{px(s):.1f}" y="{h - m + 18}" text-anchor="middle">{s:.1f}</text>')
    for k in range(5):
        v = ylo + (yhi - ylo) * k / 4
        out.append(f'<text x="{m - 6}" y="{py(v) + 4:.1f}" text-anchor="end">{v:.2f}</text>')
    out.append(f'<text x="{w / 2}" y="{h - 10}" text-anchor="middle">time (s)</text>')
    out.append(f'<text x="14" y="{h / 2}" transform="rotate(-90 14 {h / 2})" text-anchor="middle">tip displacement y (m)</text>')
    for i, (name, (t, y, colour)) in enumerate(curves.items()):
        points = " ".join(f"{px(s):.1f},{py(v):.1f}" for s, v in zip(t, y))
        out.append(f'<polyline fill="none" stroke="{colour}" stroke-width="2" points="{points}"/>')
        out.append(f'<text x="{w - m - 150}" y="{m + 18 * i}" fill="{colour}">{name}</text>')
    out.append("</svg>")
    return "\n".join(out) + "\n"


def main():
    curves, rows = {}, []
    with tempfile.TemporaryDirectory() as work:
        for scheme, colour in SCHEMES:
            t, y, newton, cg, dissipated = run(scheme, work)
            curves[scheme] = (t, y, colour)
            kept = swing(t, y, 2.0, 3.0) / swing(t, y, 0.0, 1.0)
            rows.append((scheme, kept, dissipated, newton, cg))
    open(os.path.join(ROOT, "docs", "time-schemes.svg"), "w").write(svg(curves))
    print("| scheme | tip's swing in the 3rd second / in the 1st | numerical dissipation over 3 s (J) | Newton iterations per frame | CG iterations per frame |")
    print("| --- | --- | --- | --- | --- |")
    for scheme, kept, dissipated, newton, cg in rows:
        print(f"| `{scheme}` | {kept:.2f} | {dissipated:.1f} | {newton:.2f} | {cg:.1f} |")


main()
