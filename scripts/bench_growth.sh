#!/usr/bin/env bash
# How murk's cost grows: time against pixels (3 image sizes) and against active voxels
# (3 grid sizes, up to a ≥ 25 M-voxel cloud), fitted exponents, a log–log plot.
#
#   scripts/bench_growth.sh [OUT_DIR]     (default docs/bench; ~10-20 minutes; not in CI)
#
# 1. benches/make_cloud.py writes the same fBm cloud at BENCH_GROWTH_SIZES voxels a side
#    (default "96 192 480": 0.22 M, 1.8 M and 27.6 M active voxels; its shape is fixed in
#    world space, so only the voxel count changes).
# 2. murk renders it with its defaults (fast multiple scattering, one sun, the default
#    camera framing the cloud) on BENCH_THREADS threads (default 1: the stages' seconds
#    are then CPU seconds too, and a busy machine skews them less), BENCH_RUNS times
#    (default 3; medians): the 192 cloud at BENCH_GROWTH_RES (default "240x135 480x270
#    960x540"), and every cloud at 480x270. Whole-process CPU, wall and peak RSS come
#    from /usr/bin/time, the stages' seconds from murk's --stats.
# 3. benches/growth.rs reduces the runs, prints a markdown table per sweep (each
#    stage's share, the dominant one, RSS, the map's and the density's memory) with the
#    fitted exponents, and writes OUT_DIR/growth.png and growth.md (the raw runs are
#    kept as OUT_DIR/growth.jsonl: `cargo bench --bench growth -- FILE --out DIR` redraws).
# BENCH_KEEP=1 keeps the temporary directory (clouds, images, raw results).
#
# Needs cargo, /usr/bin/time (Debian `time`), /usr/bin/python3 with pyopenvdb and numpy.
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
OUT_DIR=$(realpath -m "${1:-$ROOT/docs/bench}")
SIZES=${BENCH_GROWTH_SIZES:-"96 192 480"}
RESOLUTIONS=${BENCH_GROWTH_RES:-"240x135 480x270 960x540"}
BASE_SIZE=${BENCH_GROWTH_BASE:-192}
BASE_RES=480x270
THREADS=${BENCH_THREADS:-1}
RUNS=${BENCH_RUNS:-3}
PY=/usr/bin/python3
for tool in cargo "$PY" /usr/bin/time; do
    command -v "$tool" >/dev/null || { echo "bench_growth.sh: $tool not found" >&2; exit 2; }
done
TMP=$(mktemp -d "${TMPDIR:-/tmp}/murk-growth.XXXXXX")
if [[ "${BENCH_KEEP:-0}" == 1 ]]; then echo "bench_growth.sh: keeping $TMP" >&2; else trap 'rm -rf "$TMP"' EXIT; fi
log() { echo "bench_growth.sh: $*" >&2; }

log "building murk (cargo build --release)"
(cd "$ROOT" && cargo build --release --quiet)
MURK="$ROOT/target/release/murk"
RESULTS="$TMP/results.jsonl"
: >"$RESULTS"

for n in $SIZES; do
    log "making the cloud at ${n}³"
    "$PY" "$ROOT/benches/make_cloud.py" "$TMP/cloud$n.vdb" --size "$n" >"$TMP/cloud$n.json"
done

# render SERIES X LABEL CLOUD RES: one timed render, appended to $RESULTS.
render() {
    local series=$1 x=$2 label=$3 cloud=$4 res=$5
    /usr/bin/time -o "$TMP/time" -f '%e %U %S %M' \
        "$MURK" render "$cloud" -o "$TMP/out.exr" --res "$res" --threads "$THREADS" --quiet \
        --stats "$TMP/stats.json" 2>"$TMP/murk.err" || { cat "$TMP/murk.err" >&2; exit 1; }
    "$PY" - "$series" "$x" "$label" "$TMP/time" "$TMP/stats.json" >>"$RESULTS" <<'PY'
import json, sys
series, x, label, time_file, stats_file = sys.argv[1:]
wall, user, sys_s, rss = open(time_file).read().split()[-4:]
st = json.load(open(stats_file))
print(json.dumps({
    "series": series, "x": float(x), "label": label,
    "cpu": float(user) + float(sys_s), "wall": float(wall), "rss_kb": float(rss),
    "stages": {k: v["seconds"] for k, v in st["stages"].items()},
    "density_bytes": st.get("density_memory_bytes"), "map_bytes": st.get("shadow_map_memory_bytes"),
}))
PY
}

active() { "$PY" -c 'import json,sys; print(json.load(open(sys.argv[1]))["active_voxels"])' "$TMP/cloud$1.json"; }

for run in $(seq "$RUNS"); do
    for res in $RESOLUTIONS; do
        w=${res%x*}; h=${res#*x}
        log "run $run/$RUNS: ${BASE_SIZE}³ cloud at $res"
        render pixels $((w * h)) "${BASE_SIZE}³ cloud, $res" "$TMP/cloud$BASE_SIZE.vdb" "$res"
    done
    for n in $SIZES; do
        log "run $run/$RUNS: ${n}³ cloud at $BASE_RES"
        render voxels "$(active "$n")" "${n}³ cloud, $BASE_RES" "$TMP/cloud$n.vdb" "$BASE_RES"
    done
done

echo "_$(date -u +%Y-%m-%dT%H:%MZ), murk $(cd "$ROOT" && git rev-parse --short HEAD), $(nproc) cores, $THREADS thread(s), medians of $RUNS, load average $(cut -d' ' -f1-3 /proc/loadavg)_"
mkdir -p "$OUT_DIR"
cp "$RESULTS" "$OUT_DIR/growth.jsonl"
(cd "$ROOT" && cargo bench -q --bench growth -- "$OUT_DIR/growth.jsonl" --out "$OUT_DIR" 2>/dev/null)
