#!/usr/bin/env bash
# How murk's render scales with threads, and what it costs against the error it is asked
# for, beside vdb_render's cost against its error. Writes one JSON line per render to
# OUT/scaling.jsonl, then (where cargo is) `cargo bench --bench scaling` prints the
# tables and draws OUT/scaling.png.
#
#   scripts/bench_scaling.sh [threads|error|all] [OUT]      (default: all, OUT a temp dir)
#
# threads: benches/make_cloud.py's 192³ fBm cloud at 960x540 (the camera, σ and sun of
#          `bench.sh speed`), rendered with murk's defaults (fast) and with
#          `--scattering single --max-error 1e-2`, on 1, 2, 4, … threads up to the
#          machine's cores (and the core count itself). Whole-process wall and CPU
#          seconds (bash's `time`), each stage's wall seconds from --stats; the harness
#          takes medians and divides by the one-thread run of the same case.
# error:   the same frame with --antialias 1 (pixel centres, as vdb_render samples
#          them): murk `--scattering single --max-error E` for E in BENCH_ERRORS, and
#          vdb_render (single scattering) with -step s -shadowstep 3s for s in
#          BENCH_VDB_STEPS voxels (its defaults are s = 1). Each renderer's radiance
#          relative RMSE against its own fine reference at 1/3 of the size (its pixel
#          centres are the image's 3×3 blocks' centres): murk --reference --step 0.25,
#          vdb_render -step 0.1 -shadowstep 0.3 -cutoff 1e-6. CPU seconds of the
#          whole process, all threads.
#
# Knobs (environment): BENCH_RUNS (3), BENCH_THREAD_LIST (1 2 4 … nproc),
# BENCH_MURK (a murk binary: no cargo build; for a machine without Rust),
# BENCH_CLOUD (the 192³ cloud already made: no python needed), BENCH_RES (960x540),
# BENCH_ERRORS ("0.3 0.15 8e-2 3e-2 1e-2 3e-3 1e-3"), BENCH_VDB_STEPS ("0.25 0.5 1 2 4"),
# BENCH_REF_DIR (an earlier OUT whose references are reused), BENCH_ERROR_THREADS (nproc).
#
# Needs: bash, murk (or cargo); for `error` also /usr/bin/python3 with numpy, oiiotool
# and vdb_render (libopenvdb-tools); python3-openvdb where BENCH_CLOUD is not given.
# Not part of CI. Timings on a shared machine are noisy: compare the ratios, each taken
# within one run of this script.
set -euo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
WHAT=${1:-all}
case "$WHAT" in
    threads | error | all) ;;
    *) echo "usage: scripts/bench_scaling.sh [threads|error|all] [OUT]" >&2; exit 2 ;;
esac
OUT=${2:-$(mktemp -d "${TMPDIR:-/tmp}/murk-scaling.XXXXXX")}
mkdir -p "$OUT"
RUNS=${BENCH_RUNS:-3}
RES=${BENCH_RES:-960x540}
CORES=$(nproc)
if [[ -n "${BENCH_THREAD_LIST:-}" ]]; then
    THREAD_LIST=$BENCH_THREAD_LIST
else
    THREAD_LIST=""
    for ((t = 1; t < CORES; t *= 2)); do THREAD_LIST+="$t "; done
    THREAD_LIST+=$CORES
fi
ERRORS=${BENCH_ERRORS:-"0.3 0.15 8e-2 3e-2 1e-2 3e-3 1e-3"}
VDB_STEPS=${BENCH_VDB_STEPS:-"0.25 0.5 1 2 4"}
ERROR_THREADS=${BENCH_ERROR_THREADS:-$CORES}
PY=/usr/bin/python3
JSONL=$OUT/scaling.jsonl
log() { echo "bench_scaling.sh: $*" >&2; }

if [[ -n "${BENCH_MURK:-}" ]]; then
    MURK=$BENCH_MURK
else
    log "building murk (cargo build --release)"
    (cd "$ROOT" && cargo build --release --quiet --bin murk)
    MURK=$ROOT/target/release/murk
fi
CLOUD=${BENCH_CLOUD:-$OUT/cloud192.vdb}
if [[ ! -f "$CLOUD" ]]; then
    log "writing the 192³ cloud"
    $PY "$ROOT/benches/make_cloud.py" "$CLOUD" --size 192 >&2
fi
VOXEL=0.05 # make_cloud.py's world cube 9.6 over 192 voxels (vdb_render's σ is per voxel)
SIGMA_A=1.92
SIGMA_S=5.76
SUN=0.6,1,0.5

# murk on the cloud: OUT.exr STATS.json RES THREADS [flags]
murk_frame() {
    local out=$1 stats=$2 res=$3 threads=$4
    shift 4
    "$MURK" render "$CLOUD" -o "$out" --res "$res" --eye 0,1,18 --look-at 0,-0.4,0 --fov 40 \
        --sigma-a "$SIGMA_A,$SIGMA_A,$SIGMA_A" --sigma-s "$SIGMA_S,$SIGMA_S,$SIGMA_S" \
        --light "sun:$SUN:1,1,1:6" --float --stats "$stats" --quiet --threads "$threads" "$@"
}

# vdb_render on the cloud: OUT.exr RES STEP SHADOWSTEP [flags]
vdb_frame() {
    local out=$1 res=$2 step=$3 shadow=$4
    shift 4
    local a s
    a=$(awk "BEGIN {print $SIGMA_A * $VOXEL}")
    s=$(awk "BEGIN {print $SIGMA_S * $VOXEL}")
    vdb_render "$CLOUD" "$out" -res "$res" -translate 0,1,18 -lookat 0,-0.4,0 -up 0,1,0 -fov 40 \
        -absorb "$a,$a,$a" -scatter "$s,$s,$s" -light "$SUN,1,1,1" -cpus "$ERROR_THREADS" \
        -step "$step" -shadowstep "$shadow" "$@" >/dev/null
}

# Runs "$@", appending {"wall", "cpu"} of the whole process to the file $TIMES.
timed() {
    local TIMEFORMAT='{"wall": %R, "cpu_user": %U, "cpu_sys": %S}'
    { time "$@" 2>"$OUT/last.log"; } 2>"$TIMES"
}

# One JSON line: the fields given (as key=json-value words), the times, and the
# stats file $STATS where set (no python needed: a machine without it can run `threads`).
record() {
    local line="{" kv
    for kv in "$@"; do line+="\"${kv%%=*}\": ${kv#*=}, "; done
    line+="\"time\": $(tail -1 "$TIMES")"
    if [[ -n "${STATS:-}" ]]; then line+=", \"stats\": $(tr -d '\n' <"$STATS")"; fi
    echo "$line}" >>"$JSONL"
}

TIMES=$OUT/times.json
if [[ "$WHAT" == threads || "$WHAT" == all ]]; then
    cases=("default|" "maxerr-single|--scattering single --max-error 1e-2")
    for run in $(seq "$RUNS"); do
        for t in $THREAD_LIST; do
            for c in "${cases[@]}"; do
                IFS='|' read -r key flags <<<"$c"
                log "threads: $key on $t thread(s), run $run/$RUNS"
                # shellcheck disable=SC2086 # the flags are words
                timed murk_frame "$OUT/threads.exr" "$OUT/stats.json" "$RES" "$t" $flags
                STATS=$OUT/stats.json record kind='"threads"' case="\"$key\"" threads="$t" run="$run"
            done
        done
    done
fi

if [[ "$WHAT" == error || "$WHAT" == all ]]; then
    for tool in oiiotool vdb_render; do
        command -v "$tool" >/dev/null || { log "$tool not found"; exit 2; }
    done
    w=${RES%x*} h=${RES#*x}
    sub_res=$((w / 3))x$((h / 3))
    REF=$OUT/refs
    mkdir -p "$REF"
    if [[ -n "${BENCH_REF_DIR:-}" ]]; then cp -n "$BENCH_REF_DIR"/refs/* "$REF/" 2>/dev/null || true; fi
    if [[ ! -f "$REF/murk.exr" ]]; then
        log "error: murk --reference at $sub_res (once)"
        timed murk_frame "$REF/murk.exr" "$OUT/stats.json" "$sub_res" "$ERROR_THREADS" \
            --reference --step 0.25 --scattering single --antialias 1
    fi
    if [[ ! -f "$REF/vdb.exr" ]]; then
        log "error: vdb_render -step 0.1 at $sub_res (once)"
        timed vdb_frame "$REF/vdb.exr" "$sub_res" 0.1 0.3 -cutoff 1e-6
    fi
    err() { $PY "$ROOT/benches/bench_report.py" rel-rmse "$1" "$2" "" 3; }
    for run in $(seq "$RUNS"); do
        for e in $ERRORS; do
            log "error: murk --max-error $e, run $run/$RUNS"
            timed murk_frame "$OUT/e.exr" "$OUT/stats.json" "$RES" "$ERROR_THREADS" \
                --scattering single --max-error "$e" --antialias 1
            STATS=$OUT/stats.json record kind='"error"' renderer='"murk"' asked="$e" \
                error="$(err "$REF/murk.exr" "$OUT/e.exr")" run="$run"
        done
        for s in $VDB_STEPS; do
            log "error: vdb_render -step $s, run $run/$RUNS"
            shadow=$(awk "BEGIN {print 3 * $s}")
            timed vdb_frame "$OUT/e.exr" "$RES" "$s" "$shadow"
            STATS= record kind='"error"' renderer='"vdb_render"' step="$s" \
                error="$(err "$REF/vdb.exr" "$OUT/e.exr")" run="$run"
        done
    done
fi

cat >"$OUT/meta.json" <<EOF
{"when": "$(date -u +%Y-%m-%dT%H:%MZ)", "commit": "$(cd "$ROOT" && git rev-parse --short HEAD 2>/dev/null || echo '?')",
 "cores": $CORES, "cpu": "$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')",
 "load": "$(cut -d' ' -f1-3 /proc/loadavg)", "res": "$RES", "runs": $RUNS, "error_threads": $ERROR_THREADS}
EOF
log "results in $OUT"
if command -v cargo >/dev/null; then
    (cd "$ROOT" && cargo bench --quiet --bench scaling -- "$OUT")
fi
