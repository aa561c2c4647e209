#!/usr/bin/env bash
# The cost of motion blur: each case rendered sharp and blurred (--shutter -0.25,0.25,
# a centred 180° shutter) in the same run, at the same samples a pixel and at the same
# --max-error; prints a markdown table with the blurred/sharp ratio of the process's CPU
# seconds and of the render stage (median of BENCH_RUNS runs each).
#
#   scripts/bench_blur.sh
#
# Cases: fixtures/pyro.vdb (Houdini's vel grid; density, flame, temperature and Cd) at
# 160x90, 16 samples a pixel; the same with its density only; the 192³ fBm cloud of
# benches/make_cloud.py with the synthetic swirl of benches/add_velocity.py at 160x90, 4
# samples a pixel. The --max-error rows pass no --spp: the blurred render's samples a
# pixel are the ones the error budget chooses for the shutter's noise. One thread (BENCH_BLUR_THREADS) so that CPU seconds are the work.
#
# Knobs (environment): BENCH_RUNS (3), BENCH_BLUR_THREADS (1), BENCH_BLUR_ERROR (0.02:
# the --max-error rows), BENCH_MURK (a murk binary to measure instead of building this
# tree's), BENCH_BLUR_DIR (a folder holding cloud192_vel.vdb already made).
# Needs: cargo, /usr/bin/time, /usr/bin/python3 with pyopenvdb and numpy.
set -euo pipefail
cd "$(dirname "$0")/.."
RUNS=${BENCH_RUNS:-3}
THREADS=${BENCH_BLUR_THREADS:-1}
ERR=${BENCH_BLUR_ERROR:-0.02}
if [[ -z "${BENCH_MURK:-}" ]]; then
    cargo build --release --bin murk >&2
    BENCH_MURK=target/release/murk
fi
DIR=${BENCH_BLUR_DIR:-$(mktemp -d)}
if [[ ! -f "$DIR/cloud192_vel.vdb" ]]; then
    /usr/bin/python3 benches/make_cloud.py "$DIR/cloud192.vdb" --size 192 >&2
    /usr/bin/python3 benches/add_velocity.py "$DIR/cloud192.vdb" "$DIR/cloud192_vel.vdb" >&2
fi
export BENCH_MURK RUNS THREADS ERR DIR
/usr/bin/python3 - <<'PY'
import json, os, statistics, subprocess

murk, runs, threads, err, d = (os.environ[k] for k in ("BENCH_MURK", "RUNS", "THREADS", "ERR", "DIR"))
cases = [
    ("pyro, every grid", ["fixtures/pyro.vdb", "--res", "160x90"], "16"),
    ("pyro, density only", ["fixtures/pyro.vdb", "--res", "160x90",
                            "--emission-grid", "none", "--temperature-grid", "none", "--color-grid", "none"], "16"),
    ("cloud 192³, swirl", [f"{d}/cloud192_vel.vdb", "--res", "160x90"], "4"),
]
blur = ["--shutter", "-0.25,0.25"]

def one(args):
    out, stats, tfile = f"{d}/bench.exr", f"{d}/bench.json", f"{d}/time.txt"
    cmd = ["/usr/bin/time", "-o", tfile, "-f", "%U %S", murk, "render", *args,
           "-o", out, "--stats", stats, "--threads", threads]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    u, s = map(float, open(tfile).read().split())
    st = json.load(open(stats))
    return u + s, st["stages"]["render"]["seconds"], st["samples"]

def median(args):
    r = [one(args) for _ in range(int(runs))]
    return statistics.median(x[0] for x in r), statistics.median(x[1] for x in r), r[0][2]

print(f"| case | settings | sharp CPU s (render stage, wall s) | blurred CPU s (render stage, wall s) | ratio CPU (render stage) | samples sharp → blurred |")
print("|---|---|---|---|---|---|")
for name, args, spp in cases:
    # Under --max-error the samples a pixel are the error budget's choice: no --spp.
    for label, extra in ((f"--spp {spp}", ["--spp", spp]), (f"--max-error {err}", ["--max-error", err])):
        c0, r0, n0 = median(args + extra)
        c1, r1, n1 = median(args + extra + blur)
        print(f"| {name} | {label} | {c0:.2f} ({r0:.2f}) | {c1:.2f} ({r1:.2f}) | "
              f"{c1 / c0:.2f}× ({r1 / r0:.2f}×) | {n0 / 1e6:.2f} M → {n1 / 1e6:.2f} M |", flush=True)
PY
