#!/usr/bin/env bash
# tetsim against VegaFEM on the `tetsim bench` cantilever, side by side on this machine.
#
#   bench/peers/vegafem/run.sh [--sizes 6,12,20] [--frames 30] [--threads 2] [--work DIR]
#                              [--reuse-vega]
#
# --reuse-vega keeps VegaFEM's runs already in the work directory (to rerun only tetsim, e.g.
# with another --threads).
# Environment: TETSIM (default target/release/tetsim), VEGA_BEAM (default
# $VEGA_SRC/build-tetsim-bench/vega_beam, as build.sh makes it; VEGA_SRC default ../vega-src
# beside the repository). Needs python3 and /usr/bin/time (GNU time; Debian package `time`).
#
# For each size n: the bench's mesh is exported from tetsim (`tetsim run` of
# scenes/bench/beam_n<n>.toml for 1 frame: its frame_0000.vtu is the rest mesh; `tetsim mesh convert`
# to TetGen .node/.ele); then each code runs the whole workload (`frames` frames) and one frame,
# each under /usr/bin/time -v. CPU per frame = (user+sys of the full run - user+sys of the
# one-frame run) / (frames - 1): what a frame costs after the setup (mesh, assembly pattern).
# tetsim bench first measures STREAM (several CPU seconds, not the same in every run): the CPU
# time its process had used when it printed the STREAM line (/proc/PID/stat, by timed.py) is
# subtracted from each tetsim run first. Wall per frame is each code's own mean
# over its frames (tetsim bench's s/frame; vega_beam's clock around each time step). Newton
# iterations, CG iterations and the tip (the mean displacement of the x = 4 m face) come from the
# full runs. The load average (/proc/loadavg, 1 min) is read before and after each run.
# Memory: each process's peak resident set (GNU time). tetsim bench resets its peak
# (/proc/self/clear_refs) after STREAM, so its 768 MB of STREAM arrays are not in it.
set -euo pipefail

here=$(cd "$(dirname "$0")" && pwd)
repo=$(cd "$here/../../.." && pwd)
sizes=6,12,20
frames=30
threads=2
work=${TMPDIR:-/tmp}/tetsim-vegafem-bench
reuse_vega=0
while [ $# -gt 0 ]; do
  case "$1" in
    --sizes) sizes=$2; shift 2 ;;
    --frames) frames=$2; shift 2 ;;
    --threads) threads=$2; shift 2 ;;
    --work) work=$2; shift 2 ;;
    --reuse-vega) reuse_vega=1; shift ;;
    -h|--help) sed -n 2,30p "$0"; exit 0 ;;
    *) echo "$0: unknown argument $1" >&2; exit 2 ;;
  esac
done
tetsim=${TETSIM:-$repo/target/release/tetsim}
vega_src=${VEGA_SRC:-$repo/../vega-src}
vega=${VEGA_BEAM:-$vega_src/build-tetsim-bench/vega_beam}
for tool in "$tetsim" "$vega" /usr/bin/time; do
  [ -x "$tool" ] || { echo "$0: $tool not found or not executable (see README.md)" >&2; exit 1; }
done
[ "$frames" -ge 2 ] || { echo "$0: --frames must be at least 2" >&2; exit 2; }
mkdir -p "$work"

echo "machine: $(nproc) CPUs, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')"
echo "date: $(date -u '+%Y-%m-%d %H:%M UTC'); $("$tetsim" --version) (commit $(git -C "$repo" rev-parse --short HEAD 2>/dev/null || echo unknown)), tetsim --threads $threads; VegaFEM driver $vega"
for n in ${sizes//,/ }; do
  scene="$repo/scenes/bench/beam_n$n.toml"
  mesh="$work/beam_n$n.node"
  if [ ! -f "$mesh" ]; then
    [ -f "$scene" ] || { echo "$0: no scene $scene for n = $n" >&2; exit 1; }
    "$tetsim" run "$scene" --frames 1 --no-pictures --out "$work/rest_n$n" >/dev/null
    "$tetsim" mesh convert "$work/rest_n$n/frame_0000.vtu" "$mesh" >/dev/null
  fi
  if [ "$reuse_vega" = 1 ] && [ -f "$work/vega_n${n}_f$frames.time" ] && [ -f "$work/vega_n${n}_f1.time" ]; then
    echo "n = $n: VegaFEM's runs reused from $work" >&2
  else
    echo "n = $n: VegaFEM, $frames frames ..." >&2
    python3 "$here/timed.py" "$work/vega_n${n}_f$frames" -- "$vega" "$mesh" "$frames"
    python3 "$here/timed.py" "$work/vega_n${n}_f1" -- "$vega" "$mesh" 1
  fi
  echo "n = $n: tetsim, $frames frames ..." >&2
  for f in "$frames" 1; do
    python3 "$here/timed.py" "$work/tetsim_n${n}_f$f" --mark "STREAM triad" -- \
      "$tetsim" --threads "$threads" bench --sizes "$n" --frames "$f" --repeats 1 --json
  done
done

python3 - "$work" "$frames" "$sizes" <<'EOF'
import json, re, sys

work, frames, sizes = sys.argv[1], int(sys.argv[2]), [int(s) for s in sys.argv[3].split(",")]

def gnu_time(path):
    text = open(path).read()
    get = lambda key: float(re.search(re.escape(key) + r": *([0-9.]+)", text).group(1))
    return {"cpu": get("User time (seconds)") + get("System time (seconds)"),
            "rss_mb": get("Maximum resident set size (kbytes)") / 1024}

def vega(n, f):
    line = [l for l in open(f"{work}/vega_n{n}_f{f}.out") if l.startswith("RESULT ")][-1]
    return json.loads(line[len("RESULT "):]) | gnu_time(f"{work}/vega_n{n}_f{f}.time")

def tetsim(n, f):
    text = open(f"{work}/tetsim_n{n}_f{f}.out").read()
    report = json.loads(text[text.index("{"):])
    size = report["sizes"][0]
    # The CPU time the bench had spent when its STREAM measurement ended, taken out.
    stream_cpu = float(open(f"{work}/tetsim_n{n}_f{f}.mark").read())
    timed = gnu_time(f"{work}/tetsim_n{n}_f{f}.time")
    timed["cpu"] -= stream_cpu
    return size | {"stream": report["stream_triad_gb_per_s"], "stream_cpu": stream_cpu} | timed

def loads(who, n):
    return [float(x) for f in (frames, 1) for x in open(f"{work}/{who}_n{n}_f{f}.load").read().split()]

rows, notes = [], []
for n in sizes:
    v, v1, t, t1 = vega(n, frames), vega(n, 1), tetsim(n, frames), tetsim(n, 1)
    v_cpu = (v["cpu"] - v1["cpu"]) / (frames - 1)
    t_cpu = (t["cpu"] - t1["cpu"]) / (frames - 1)
    v_tip, t_tip = v["tip_norm"], (sum(c * c for c in t["tip_displacement"])) ** 0.5
    rows.append([n, f"{t['tets']:,}",
                 f"{v['wall_per_frame_s']:.3f}", f"{t['seconds_per_frame']:.3f}",
                 f"{v['wall_per_frame_s'] / t['seconds_per_frame']:.1f}",
                 f"{v_cpu:.3f}", f"{t_cpu:.3f}", f"{v_cpu / t_cpu:.1f}",
                 f"{v['newton_per_frame']:.2f}", f"{t['newton_per_frame']:.2f}",
                 f"{v['cg_per_newton']:.0f}", f"{t['cg_per_newton']:.1f}",
                 f"{v_tip:.6f}", f"{t_tip:.6f}", f"{(v_tip - t_tip) / t_tip:+.1e}",
                 f"{v['rss_mb']:.0f}", f"{t['rss_mb']:.0f}"])
    notes.append(f"n = {n}: VegaFEM in-process CPU {v['cpu_per_frame_s']:.3f} s/frame "
                 f"(setup {v['setup_cpu_s']:.2f} s), unconverged frames {v['unconverged_frames']}, "
                 f"CG failures {v['cg_failures']}; tetsim all converged {t['all_converged']}, "
                 f"STREAM {t['stream']:.1f} / {t1['stream']:.1f} GB/s (CPU {t['stream_cpu']:.1f} / {t1['stream_cpu']:.1f} s, subtracted); load average "
                 f"VegaFEM {'/'.join(f'{x:.1f}' for x in loads('vega', n))}, "
                 f"tetsim {'/'.join(f'{x:.1f}' for x in loads('tetsim', n))} (before/after, full then 1-frame run)")

head = ["n", "tets", "Vega wall s/fr", "tetsim wall s/fr", "wall ×", "Vega CPU s/fr",
        "tetsim CPU s/fr", "CPU ×", "Vega Newton/fr", "tetsim Newton/fr", "Vega CG/Newton",
        "tetsim CG/Newton", "Vega tip \\|u\\| m", "tetsim tip \\|u\\| m", "tip (Vega − tetsim)/tetsim",
        "Vega peak MiB", "tetsim peak MiB"]
print("| " + " | ".join(head) + " |")
print("| " + " | ".join("---" for _ in head) + " |")
for r in rows:
    print("| " + " | ".join(str(c) for c in r) + " |")
print()
for line in notes:
    print(line)
EOF
