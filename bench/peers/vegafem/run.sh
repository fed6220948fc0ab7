#!/usr/bin/env bash
# tetsim against VegaFEM on the `tetsim bench` cantilever, side by side on this machine.
#
#   bench/peers/vegafem/run.sh [--sizes 6,12,20] [--frames 30] [--threads 2] [--work DIR]
#
# Environment: TETSIM (default target/release/tetsim), VEGA_BEAM (default
# $VEGA_SRC/build-tetsim-bench/vega_beam, as build.sh makes it; VEGA_SRC default ../vega-src
# beside the repository). Needs python3 and /usr/bin/time (GNU time; Debian package `time`).
#
# For each size n: the bench's mesh is exported from tetsim (`tetsim run` of
# scenes/bench/beam_n<n>.toml for 0 frames' output: frame_0000.vtu, then `tetsim mesh convert`
# to TetGen .node/.ele); then each code runs the whole workload (`frames` frames) and one frame,
# each under /usr/bin/time -v. CPU per frame = (user+sys of the full run - user+sys of the
# one-frame run) / (frames - 1): what a frame costs after the setup (mesh, assembly pattern,
# tetsim's STREAM measurement, which both runs share). Wall per frame is each code's own mean
# over its frames (tetsim bench's s/frame; vega_beam's clock around each time step). Newton
# iterations, CG iterations and the tip (the mean displacement of the x = 4 m face) come from the
# full runs. The load average (/proc/loadavg, 1 min) is read before and after each run.
# Memory: VegaFEM's peak resident set (GNU time; it allocates everything at setup); tetsim's
# resident set at the end of the run as the bench reports it (the peak of its process includes
# the bench's 768 MB STREAM arrays).
set -euo pipefail

here=$(cd "$(dirname "$0")" && pwd)
repo=$(cd "$here/../../.." && pwd)
sizes=6,12,20
frames=30
threads=2
work=${TMPDIR:-/tmp}/tetsim-vegafem-bench
while [ $# -gt 0 ]; do
  case "$1" in
    --sizes) sizes=$2; shift 2 ;;
    --frames) frames=$2; shift 2 ;;
    --threads) threads=$2; shift 2 ;;
    --work) work=$2; shift 2 ;;
    -h|--help) sed -n 2,18p "$0"; exit 0 ;;
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

load() { cut -d' ' -f1 /proc/loadavg; }

# timed LOG CMD...: run CMD with stdout to LOG.out, GNU time's report to LOG.time, and the load
# average before and after to LOG.load.
timed() {
  local log=$1
  shift
  echo "$(load)" >"$log.load"
  /usr/bin/time -v -o "$log.time" "$@" >"$log.out"
  echo "$(load)" >>"$log.load"
}

echo "machine: $(nproc) CPUs, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')"
echo "date: $(date -u '+%Y-%m-%d %H:%M UTC'), tetsim $("$tetsim" --version), VegaFEM driver $vega"
for n in ${sizes//,/ }; do
  scene="$repo/scenes/bench/beam_n$n.toml"
  mesh="$work/beam_n$n.node"
  if [ ! -f "$mesh" ]; then
    [ -f "$scene" ] || { echo "$0: no scene $scene for n = $n" >&2; exit 1; }
    "$tetsim" run "$scene" --frames 0 --no-pictures --out "$work/rest_n$n" >/dev/null
    "$tetsim" mesh convert "$work/rest_n$n/frame_0000.vtu" "$mesh" >/dev/null
  fi
  echo "n = $n: VegaFEM, $frames frames ..." >&2
  timed "$work/vega_n${n}_f$frames" "$vega" "$mesh" "$frames"
  timed "$work/vega_n${n}_f1" "$vega" "$mesh" 1
  echo "n = $n: tetsim, $frames frames ..." >&2
  timed "$work/tetsim_n${n}_f$frames" "$tetsim" --threads "$threads" bench --sizes "$n" \
    --frames "$frames" --repeats 1 --json
  timed "$work/tetsim_n${n}_f1" "$tetsim" --threads "$threads" bench --sizes "$n" \
    --frames 1 --repeats 1 --json
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
    return size | {"stream": report["stream_triad_gb_per_s"]} | gnu_time(f"{work}/tetsim_n{n}_f{f}.time")

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
                 f"{v_tip:.6f}", f"{t_tip:.6f}", f"{(v_tip - t_tip) / t_tip:+.2%}",
                 f"{v['rss_mb']:.0f}", f"{t['resident_mb']:.0f}"])
    notes.append(f"n = {n}: VegaFEM in-process CPU {v['cpu_per_frame_s']:.3f} s/frame "
                 f"(setup {v['setup_cpu_s']:.2f} s), unconverged frames {v['unconverged_frames']}, "
                 f"CG failures {v['cg_failures']}; tetsim all converged {t['all_converged']}, "
                 f"STREAM {t['stream']:.1f} / {t1['stream']:.1f} GB/s; load average "
                 f"VegaFEM {'/'.join(f'{x:.1f}' for x in loads('vega', n))}, "
                 f"tetsim {'/'.join(f'{x:.1f}' for x in loads('tetsim', n))} (before/after, full then 1-frame run)")

head = ["n", "tets", "Vega wall s/fr", "tetsim wall s/fr", "wall ×", "Vega CPU s/fr",
        "tetsim CPU s/fr", "CPU ×", "Vega Newton/fr", "tetsim Newton/fr", "Vega CG/Newton",
        "tetsim CG/Newton", "Vega tip |u| m", "tetsim tip |u| m", "tip Vega-tetsim",
        "Vega peak RSS MB", "tetsim RSS MB"]
print("| " + " | ".join(head) + " |")
print("| " + " | ".join("---" for _ in head) + " |")
for r in rows:
    print("| " + " | ".join(str(c) for c in r) + " |")
print()
for line in notes:
    print(line)
EOF
