#!/usr/bin/env bash
# Benchmarks murk against OpenVDB, measured in the same run; prints a markdown table.
#
#   scripts/bench.sh [load|memory|render|shadow|emission|all]      (default: all)
#
# load:   a 264³ grid (18.4 M active voxels; float and half) made at run time by
#         benches/make_big_grid.py. murk's VdbFile::open + VoxelGrid::load against
#         pyopenvdb.readAll (time, peak RSS), each in a fresh process; then trilinear
#         samples per second, murk's value_at_index against OpenVDB-rs's BoxSampler with
#         a cached ValueAccessor (benches/grid.rs). Then the memory part (#14 target 3,
#         both figures in the same run).
# memory: the large cloud (benches/make_cloud.py --size BENCH_MEMORY_SIZE, 480: 27.6 M
#         active voxels) rendered with murk's defaults at 480x270: the whole process's peak
#         RSS (/usr/bin/time) against the density structure's bytes (--stats), target ≤ 3×.
# render: fixtures/cloud.vdb at 960x540, murk (release; single scattering, as vdb_render; --shadows dsm,
#         march and none, and --max-error 1e-2 choosing its own settings) against vdb_render (and vdb_render with -shadowstep 1000: its shadows all but
#         off, the floor of its cost) with the same camera, σ (murk's per world unit = vdb_render's
#         per voxel / voxel size) and primary step in voxels; alpha error of both against a
#         fine-step murk reference; whole-process wall time and peak RSS; the shadow map's
#         bake time and memory against the density structure's.
# shadow: the deep shadow map's targets (#14 target 2) on the demo cloud at 960x540 and a
#         generated large cloud (benches/make_big_grid.py, BENCH_SHADOW_SIZE³ voxels, all
#         active) at 480x270, murk's default camera and medium: the map's memory against
#         the density structure's (target ≤ 2×), the bake's share of the whole run (≤ 25 %),
#         the lookups' share of the render stage (≤ 30 %), and --dsm-verify's max error
#         (≤ 2× the tolerance). Shares in process CPU seconds: bake = the 16x9 run with the
#         map minus the one without; render stage = a run minus its 16x9 twin; lookups =
#         the render stage with the map minus the one with --shadows none.
# emission: the three production fixtures (fixtures/blender_smoke.vdb, houdini_pyro.vdb,
#         pyro.vdb), each rendered with its emission (flame and temperature grids as
#         detected) and without it (--emission-grid none --temperature-grid none), in the
#         same run, at BENCH_EMISSION_RES with BENCH_EMISSION_THREADS threads, for each of
#         BENCH_EMISSION_SCATTERING; CPU and wall seconds of the whole process and the
#         render stage, samples, and the ratio with/without against the 1.5× target.
#
# Knobs (environment): BENCH_RUNS (3), BENCH_THREADS (nproc), BENCH_RES (960x540),
# BENCH_STEPS ("1 0.5": primary steps in voxels), BENCH_SHADOW_STEP (1),
# BENCH_REF_STEP (0.05: murk's reference), BENCH_CONV_STEP (0.1: vdb_render's convention
# check), BENCH_GRID_SIZE (264), BENCH_SAMPLE_REPS (5), BENCH_SHADOW_SIZE (300: 27 M
# voxels), BENCH_MEMORY_SIZE (480), BENCH_SHADOW_THREADS (1), BENCH_DSM_TOL (1e-3), BENCH_MURK (shadow: a murk
# binary to measure instead of building this tree's, e.g. an older one for "before"),
# BENCH_SHADOW_VDB (shadow: a large cloud already made, instead of writing one),
# BENCH_EMISSION_RES (480x270), BENCH_EMISSION_THREADS (1), BENCH_EMISSION_SCATTERING
# ("single fast"), BENCH_KEEP=1 keeps the temporary directory (images, raw JSON).
#
# Needs: cargo, /usr/bin/time (Debian package `time`), /usr/bin/python3 with pyopenvdb and numpy (python3-openvdb), vdb_render
# (libopenvdb-tools), oiiotool (openimageio-tools). Not part of CI: run it by hand, on a
# quiet machine if you can.
set -euo pipefail
set -a # variables reach the functions `timed` runs in a child bash

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
WHAT=${1:-all}
RUNS=${BENCH_RUNS:-3}
THREADS=${BENCH_THREADS:-$(nproc)}
RES=${BENCH_RES:-960x540}
STEPS=${BENCH_STEPS:-"1 0.5"}
SHADOW_STEP=${BENCH_SHADOW_STEP:-1}
REF_STEP=${BENCH_REF_STEP:-0.05}
CONV_STEP=${BENCH_CONV_STEP:-0.1}
GRID_SIZE=${BENCH_GRID_SIZE:-264}
SAMPLE_REPS=${BENCH_SAMPLE_REPS:-5}
SHADOW_SIZE=${BENCH_SHADOW_SIZE:-300}
MEMORY_SIZE=${BENCH_MEMORY_SIZE:-480}
SHADOW_THREADS=${BENCH_SHADOW_THREADS:-1}
DSM_TOL=${BENCH_DSM_TOL:-1e-3}
EMISSION_RES=${BENCH_EMISSION_RES:-480x270}
EMISSION_THREADS=${BENCH_EMISSION_THREADS:-1}
EMISSION_SCATTERING=${BENCH_EMISSION_SCATTERING:-"single fast"}
PY=/usr/bin/python3
REPORT="$PY $ROOT/benches/bench_report.py"

case "$WHAT" in
    load | memory | render | shadow | emission | all) ;;
    *) echo "usage: scripts/bench.sh [load|memory|render|shadow|emission|all]" >&2; exit 2 ;;
esac
tools=(cargo "$PY" /usr/bin/time)
[[ "$WHAT" == emission || "$WHAT" == memory ]] || tools+=(oiiotool vdb_render)
for tool in "${tools[@]}"; do
    command -v "$tool" >/dev/null || { echo "bench.sh: $tool not found" >&2; exit 2; }
done

TMP=$(mktemp -d "${TMPDIR:-/tmp}/murk-bench.XXXXXX")
cleanup() {
    if [[ "${BENCH_KEEP:-0}" == 1 ]]; then echo "bench.sh: kept $TMP" >&2; else rm -rf "$TMP"; fi
}
trap cleanup EXIT
OUT="$TMP/results"
mkdir -p "$OUT"

log() { echo "bench.sh: $*" >&2; }

# Runs "$@" under /usr/bin/time: "real user sys maxrss_kb" go to the file named by
# $TIME_TO, the command's stdout and stderr to $LOG_TO.
# (The commands are often this script's functions: they and its variables are exported,
# and run in a child bash.)
timed() {
    if ! /usr/bin/time -o "$TIME_TO" -f '%e %U %S %M' bash -c '"$@"' timed "$@" >"$LOG_TO" 2>&1; then
        log "failed: $*"
        cat "$LOG_TO" >&2
        return 1
    fi
}

# ------------------------------------------------------------------ A. load
bench_load() {
    log "building the grid benchmark (cargo bench --no-run)"
    local exe
    exe=$(cd "$ROOT" && cargo bench --bench grid --no-run --message-format=json 2>/dev/null |
        $PY -c 'import json, sys
for line in sys.stdin:
    m = json.loads(line)
    if m.get("reason") == "compiler-artifact" and m.get("target", {}).get("name") == "grid" and m.get("executable"):
        print(m["executable"])')
    [[ -x "$exe" ]] || { log "could not build benches/grid.rs"; exit 1; }

    log "writing the ${GRID_SIZE}³ grids"
    $PY "$ROOT/benches/make_big_grid.py" "$TMP/grids" --size "$GRID_SIZE" >&2

    for kind in float half; do
        local f="$TMP/grids/big_$kind.vdb"
        for run in $(seq "$RUNS"); do
            log "load $kind, run $run/$RUNS"
            "$exe" load "$f" >"$OUT/load-murk-$kind.$run.json"
            # OpenVDB maps the file and decodes leaf buffers lazily unless told not to.
            OPENVDB_DISABLE_DELAYED_LOAD=1 $PY "$ROOT/benches/openvdb_load.py" "$f" >"$OUT/load-openvdb-$kind.$run.json"
        done
        log "sampling $kind ($SAMPLE_REPS repetitions, single thread)"
        "$exe" sample "$f" --reps "$SAMPLE_REPS" >"$OUT/sample-$kind.1.json"
    done
}

# The large cloud's peak memory (#14 target 3): the whole process against the density
# structure murk keeps for the render.
bench_memory() {
    log "building murk (cargo build --release)"
    (cd "$ROOT" && cargo build --release --quiet)
    local murk="$ROOT/target/release/murk" vdb="$TMP/cloud${MEMORY_SIZE}.vdb" run
    log "writing the ${MEMORY_SIZE}³ cloud"
    $PY "$ROOT/benches/make_cloud.py" "$vdb" --size "$MEMORY_SIZE" >&2
    for run in $(seq "$RUNS"); do
        log "large cloud, 480x270, murk's defaults: run $run/$RUNS"
        TIME_TO="$TMP/time" LOG_TO="$TMP/murk.log" timed \
            "$murk" render "$vdb" -o "$TMP/memory.exr" --res 480x270 --stats "$TMP/stats.json" --quiet
        $REPORT run "$OUT/memory-large.$run.json" --time "$TMP/time" --murk-stats "$TMP/stats.json"
    done
}

# ------------------------------------------------------------------ B. render
# The demo cloud: voxel size 0.05, index bbox (-40,-21,-40)-(43,31,39).
CLOUD="$ROOT/fixtures/cloud.vdb"
VOXEL=0.05
EYE=0.1,2.3,6.7
LOOK=0.075,0.25,-0.025
FOV=40 # horizontal, for both (vdb_render's -fov is horizontal: aperture is the frame width)
SIGMA_A=0.1 # per world unit (murk); vdb_render takes σ per voxel = σ · voxel size
SIGMA_S=2
SUN=0.6,1,0.5 # direction toward the light, for both
VDB_CUTOFF_DEFAULT=0.005
# vdb_render stops a ray when |T|² = Σ T_c² < cutoff, so T < sqrt(cutoff/3) for grey
# media; murk stops at T < 1e-4 (its --termination): cutoff 3e-8 matches that.
VDB_CUTOFF_MATCHED=3e-8
VDB_CUTOFF_TINY=1e-12

vdb_sigma() { $PY -c "print($1 * $VOXEL)"; }

murk_render() { # OUT.exr STATS.json STEP SHADOWS [extra flags]
    local out=$1 stats=$2 step=$3 shadows=$4
    shift 4
    "$MURK" render "$CLOUD" -o "$out" --res "$RES" --eye "$EYE" --look-at "$LOOK" --fov "$FOV" \
        --sigma-a "$SIGMA_A,$SIGMA_A,$SIGMA_A" --sigma-s "$SIGMA_S,$SIGMA_S,$SIGMA_S" \
        --light "sun:$SUN:1,1,1:6" --step "$step" --shadows "$shadows" --shadow-step "$SHADOW_STEP" \
        --scattering single --float --stats "$stats" --quiet --threads "$THREADS" "$@"
}

# murk choosing its own step, tolerance and termination for a relative radiance error of
# 1e-2 against its --reference (#14): OUT.exr STATS.json. Single scattering, as
# vdb_render (murk's default adds the fast multiple-scattering lattice).
murk_render_budget() {
    "$MURK" render "$CLOUD" -o "$1" --res "$RES" --eye "$EYE" --look-at "$LOOK" --fov "$FOV" \
        --sigma-a "$SIGMA_A,$SIGMA_A,$SIGMA_A" --sigma-s "$SIGMA_S,$SIGMA_S,$SIGMA_S" \
        --light "sun:$SUN:1,1,1:6" --max-error 1e-2 --shadow-step "$SHADOW_STEP" \
        --scattering single --float --stats "$2" --quiet --threads "$THREADS"
}

vdb_render_run() { # OUT.exr STEP CUTOFF SHADOWSTEP [VDB]
    local a s
    a=$(vdb_sigma "$SIGMA_A")
    s=$(vdb_sigma "$SIGMA_S")
    vdb_render "${5:-$CLOUD}" "$1" -res "$RES" -translate "$EYE" -lookat "$LOOK" -up 0,1,0 -fov "$FOV" \
        -absorb "$a,$a,$a" -scatter "$s,$s,$s" -light "$SUN,1,1,1" -step "$2" -shadowstep "$4" \
        -cutoff "$3" -cpus "$THREADS" -v
}

export -f vdb_sigma murk_render murk_render_budget vdb_render_run

# Alpha error of IMAGE against the reference, as JSON in $TMP/err.json.
alpha_err() {
    $REPORT alpha "$1" "$TMP/test.fits"
    $REPORT alpha-error "$TMP/ref.fits" "$TMP/test.fits" >"$TMP/err.json"
}

bench_render() {
    log "building murk (cargo build --release)"
    (cd "$ROOT" && cargo build --release --quiet)
    MURK="$ROOT/target/release/murk"
    local img="$TMP/img"
    mkdir -p "$img"

    log "reference: murk --step $REF_STEP --shadows none"
    murk_render "$img/ref.exr" "$TMP/ref.stats.json" "$REF_STEP" none
    $REPORT alpha "$img/ref.exr" "$TMP/ref.fits"

    # Convention check: a fine-step vdb_render should converge to the same alpha (shadow
    # step huge: shadows do not change alpha, and would only cost time). Also on a copy
    # with the active topology dilated by a voxel: vdb_render integrates only inside
    # active leaves, and so misses the trilinear ramp below a leaf with no neighbour.
    $PY "$ROOT/benches/dilate_topology.py" "$CLOUD" density "$TMP/cloud_dilated.vdb"
    for variant in converged converged-dilated; do
        local vdb=$CLOUD
        [[ $variant == converged-dilated ]] && vdb=$TMP/cloud_dilated.vdb
        log "convention check: vdb_render -step $CONV_STEP on $(basename "$vdb")"
        TIME_TO="$TMP/time" LOG_TO="$TMP/vdb.log" timed \
            vdb_render_run "$img/vdb-$variant.exr" "$CONV_STEP" "$VDB_CUTOFF_TINY" 1000 "$vdb"
        alpha_err "$img/vdb-$variant.exr"
        $REPORT run "$OUT/render-vdb-$variant.1.json" --time "$TMP/time" --vdb-log "$TMP/vdb.log" \
            --extra "$TMP/err.json"
    done

    for step in $STEPS; do
        for run in $(seq "$RUNS"); do
            for shadows in dsm march none; do
                log "step $step: murk --shadows $shadows, run $run/$RUNS"
                local name="murk-$shadows-s$step"
                TIME_TO="$TMP/time" LOG_TO="$TMP/murk.log" timed \
                    murk_render "$img/$name.exr" "$TMP/stats.json" "$step" "$shadows"
                alpha_err "$img/$name.exr"
                $REPORT run "$OUT/render-$name.$run.json" --time "$TMP/time" --murk-stats "$TMP/stats.json" \
                    --extra "$TMP/err.json"
            done
            # The step is murk's to choose here; run once per step row to sit beside it.
            log "step $step (ignored): murk --max-error 1e-2, run $run/$RUNS"
            local name="murk-maxerr-s$step"
            TIME_TO="$TMP/time" LOG_TO="$TMP/murk.log" timed \
                murk_render_budget "$img/$name.exr" "$TMP/stats.json"
            alpha_err "$img/$name.exr"
            $REPORT run "$OUT/render-$name.$run.json" --time "$TMP/time" --murk-stats "$TMP/stats.json" \
                --extra "$TMP/err.json"
            for cut in default matched; do
                local cutoff=$VDB_CUTOFF_DEFAULT
                [[ $cut == matched ]] && cutoff=$VDB_CUTOFF_MATCHED
                log "step $step: vdb_render -cutoff $cutoff, run $run/$RUNS"
                local name="vdb-$cut-s$step"
                TIME_TO="$TMP/time" LOG_TO="$TMP/vdb.log" timed \
                    vdb_render_run "$img/$name.exr" "$step" "$cutoff" "$SHADOW_STEP"
                alpha_err "$img/$name.exr"
                $REPORT run "$OUT/render-$name.$run.json" --time "$TMP/time" --vdb-log "$TMP/vdb.log" \
                    --extra "$TMP/err.json"
            done
            # vdb_render's march with its shadows all but off (one shadow sample per
            # primary sample): the floor of its cost, which the map's target is set against.
            log "step $step: vdb_render -shadowstep 1000, run $run/$RUNS"
            local name="vdb-noshadow-s$step"
            TIME_TO="$TMP/time" LOG_TO="$TMP/vdb.log" timed \
                vdb_render_run "$img/$name.exr" "$step" "$VDB_CUTOFF_DEFAULT" 1000
            alpha_err "$img/$name.exr"
            $REPORT run "$OUT/render-$name.$run.json" --time "$TMP/time" --vdb-log "$TMP/vdb.log" \
                --extra "$TMP/err.json"
        done
    done
}

# ------------------------------------------------------------------ C. shadow
bench_shadow() {
    if [[ -n "${BENCH_MURK:-}" ]]; then
        MURK=$BENCH_MURK
    else
        log "building murk (cargo build --release)"
        (cd "$ROOT" && cargo build --release --quiet)
        MURK="$ROOT/target/release/murk"
    fi
    if [[ -n "${BENCH_SHADOW_VDB:-}" ]]; then
        mkdir -p "$TMP/shadow" && ln -s "$BENCH_SHADOW_VDB" "$TMP/shadow/big_float.vdb"
    else
        log "writing the ${SHADOW_SIZE}³ cloud"
        $PY "$ROOT/benches/make_big_grid.py" "$TMP/shadow" --size "$SHADOW_SIZE" >&2
    fi
    local cloud vdb res run shadows
    for cloud in demo large; do
        vdb=$CLOUD res=960x540
        [[ $cloud == large ]] && vdb=$TMP/shadow/big_float.vdb res=480x270
        # CPU seconds, steadier than the stages' wall seconds on a shared machine: the
        # same runs at 16x9 give the cost that does not grow with pixels (load, bake),
        # with the map and without; the render stage's CPU is the rest.
        for run in $(seq "$RUNS"); do
            for shadows in dsm none; do
                for r in "$res" 16x9; do
                    local tag=$shadows
                    [[ $r == 16x9 ]] && tag=$shadows-tiny
                    log "$cloud cloud, $r: murk --shadows $shadows, run $run/$RUNS"
                    TIME_TO="$TMP/time" LOG_TO="$TMP/murk.log" timed \
                        "$MURK" render "$vdb" -o "$TMP/shadow.exr" --res "$r" --shadows "$shadows" \
                        --dsm-tolerance "$DSM_TOL" --stats "$TMP/stats.json" --quiet --threads "$SHADOW_THREADS"
                    $REPORT run "$OUT/shadow-$cloud-$tag.$run.json" --time "$TMP/time" --murk-stats "$TMP/stats.json"
                done
            done
        done
        # The map and its verification do not depend on the image: a tiny one.
        log "$cloud cloud: murk --dsm-verify"
        TIME_TO="$TMP/time" LOG_TO="$TMP/murk.log" timed \
            "$MURK" render "$vdb" -o "$TMP/shadow.exr" --res 16x9 --dsm-tolerance "$DSM_TOL" --dsm-verify \
            --stats "$TMP/stats.json" --quiet --threads "$SHADOW_THREADS"
        $REPORT run "$OUT/shadow-$cloud-verify.1.json" --time "$TMP/time" --murk-stats "$TMP/stats.json"
    done
}

# ------------------------------------------------------------------ D. emission
EMISSION_FIXTURES="blender_smoke houdini_pyro pyro"

murk_emission() { # FIXTURE OUT.exr STATS.json SCATTERING [extra flags]
    local fixture=$1 out=$2 stats=$3 scattering=$4
    shift 4
    "$MURK" render "$ROOT/fixtures/$fixture.vdb" -o "$out" --res "$EMISSION_RES" --threads "$EMISSION_THREADS" \
        --scattering "$scattering" --stats "$stats" --quiet "$@"
}
export -f murk_emission

bench_emission() {
    log "building murk (cargo build --release)"
    (cd "$ROOT" && cargo build --release --quiet)
    MURK="$ROOT/target/release/murk"
    for run in $(seq "$RUNS"); do
        for scattering in $EMISSION_SCATTERING; do
            for fixture in $EMISSION_FIXTURES; do
                # With and without emission back to back, so both see the same load.
                for emission in on off; do
                    local flags=()
                    [[ $emission == off ]] && flags=(--emission-grid none --temperature-grid none)
                    log "emission $emission: $fixture, --scattering $scattering, run $run/$RUNS"
                    TIME_TO="$TMP/time" LOG_TO="$TMP/murk.log" timed \
                        murk_emission "$fixture" "$TMP/emission.exr" "$TMP/stats.json" "$scattering" "${flags[@]}"
                    $REPORT run "$OUT/emission-$fixture-$scattering-$emission.$run.json" --time "$TMP/time" \
                        --murk-stats "$TMP/stats.json"
                done
            done
        done
    done
}

if [[ "$WHAT" == load || "$WHAT" == all ]]; then bench_load; fi
if [[ "$WHAT" == load || "$WHAT" == memory || "$WHAT" == all ]]; then bench_memory; fi
if [[ "$WHAT" == render || "$WHAT" == all ]]; then bench_render; fi
if [[ "$WHAT" == shadow || "$WHAT" == all ]]; then bench_shadow; fi
if [[ "$WHAT" == emission || "$WHAT" == all ]]; then bench_emission; fi

steps_json=$($PY -c 'import json, sys; print(json.dumps(sys.argv[1].split()))' "$STEPS")
cat >"$OUT/meta.info" <<EOF
{"when": "$(date -u +%Y-%m-%dT%H:%MZ), murk $(cd "$ROOT" && git rev-parse --short HEAD 2>/dev/null || echo '?')",
 "runs": $RUNS, "cores": $(nproc), "threads": $THREADS, "load": "$(cut -d' ' -f1-3 /proc/loadavg)",
 "emission_res": "$EMISSION_RES", "emission_threads": $EMISSION_THREADS, "res": "$RES", "steps": $steps_json,
 "camera": "eye $EYE, look-at $LOOK, horizontal fov $FOV°; σa $SIGMA_A, σs $SIGMA_S per world unit; shadow step $SHADOW_STEP voxel",
 "reference": "murk --step $REF_STEP --shadows none",
 "ref_step": "$REF_STEP", "conv_step": "$CONV_STEP",
 "memory_size": $MEMORY_SIZE, "dsm_tolerance": "$DSM_TOL", "shadow_threads": $SHADOW_THREADS, "shadow_clouds": ["demo", "large"],
 "shadow_res": {"demo": "960x540 (fixtures/cloud.vdb)", "large": "480x270 (${SHADOW_SIZE}³ generated)"},
 "vdb_cutoff_default": "$VDB_CUTOFF_DEFAULT", "vdb_cutoff_matched": "$VDB_CUTOFF_MATCHED", "vdb_cutoff_tiny": "$VDB_CUTOFF_TINY"}
EOF
echo
$REPORT table "$OUT"
