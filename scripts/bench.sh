#!/usr/bin/env bash
# Benchmarks murk against OpenVDB, measured in the same run; prints a markdown table.
#
#   scripts/bench.sh [load|memory|render|shadow|emission|speed|all]      (default: all)
#
# load:   a 264³ grid (18.4 M active voxels; float and half) made at run time by
#         benches/make_big_grid.py. murk's VdbFile::open + VoxelGrid::load against
#         pyopenvdb.readAll (time, peak RSS), each in a fresh process; then trilinear
#         samples per second, murk's value_at_index against OpenVDB-rs's BoxSampler with
#         a cached ValueAccessor (benches/grid.rs). Then the memory part (target: 3x the density,
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
# shadow: the deep shadow map's targets on the demo cloud at 960x540 and a
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
# speed:  the speed target against vdb_render: the fBm cloud of benches/make_cloud.py at
#         192³ (1.8 M voxels) rendered at 960x540 and at 480³ (27.6 M) at 480x270, the
#         same camera, σ (σa 1.92, σs 5.76 per world unit; per voxel for vdb_render) and
#         sun for both renderers. Rows: vdb_render with its defaults (step 1, shadow step
#         3, -cutoff 0.005); murk --max-error 1e-2 in single scattering (as vdb_render)
#         and in its default fast mode; murk with no flags. Whole-process CPU and wall
#         (/usr/bin/time), murk's stages; alpha RMSE of every row against murk's
#         --reference (single scattering; exact optical depth, no termination), radiance
#         relative RMSE of murk's rows against murk's --reference in the same scattering
#         mode; the CPU ratio against vdb_render and the targets (≤ 0.10× with
#         --max-error 1e-2 at equal or lower alpha error and radiance within 1e-2; ≤ 0.25×
#         for the default).
#
# Knobs (environment): BENCH_RUNS (3), BENCH_THREADS (nproc), BENCH_RES (960x540),
# BENCH_STEPS ("1 0.5": primary steps in voxels), BENCH_SHADOW_STEP (1),
# BENCH_REF_STEP (0.05: murk's reference), BENCH_CONV_STEP (0.1: vdb_render's convention
# check), BENCH_GRID_SIZE (264), BENCH_SAMPLE_REPS (5), BENCH_SHADOW_SIZE (300: 27 M
# voxels), BENCH_MEMORY_SIZE (480), BENCH_SHADOW_THREADS (1), BENCH_DSM_TOL (1e-3), BENCH_MURK (shadow: a murk
# binary to measure instead of building this tree's, e.g. an older one for "before"),
# BENCH_SHADOW_VDB (shadow: a large cloud already made, instead of writing one),
# BENCH_EMISSION_RES (480x270), BENCH_EMISSION_THREADS (1), BENCH_EMISSION_SCATTERING
# ("single fast"), BENCH_SPEED_CLOUDS ("192:960x540 480:480x270": size:res),
# BENCH_SPEED_DIR (a directory holding cloudN.vdb already made by make_cloud.py; made
# in the temporary directory otherwise), BENCH_SPEED_REF_STEP (0.25: the --reference's
# source step, voxels; its own error is ~1e-4, far below the 1e-2 measured against it),
# BENCH_SPEED_FAST_REF (1: also a --reference in fast scattering, for the fast rows'
# radiance error), BENCH_SPEED_REF_SUB (3, odd: the radiance references are rendered at
# 1/3 of the size, their pixel centres every third pixel's), BENCH_SPEED_REF_DIR (a
# directory BENCH_KEEP=1 kept from an earlier speed run: its references are reused, as
# they depend on the scene alone; ~15 of the mode's ~25 minutes), BENCH_KEEP=1 keeps the temporary directory (images, raw JSON).
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
SPEED_CLOUDS=${BENCH_SPEED_CLOUDS:-"192:960x540 480:480x270"}
SPEED_REF_STEP=${BENCH_SPEED_REF_STEP:-0.25}
SPEED_FAST_REF=${BENCH_SPEED_FAST_REF:-1}
SPEED_REF_SUB=${BENCH_SPEED_REF_SUB:-3}
PY=/usr/bin/python3
REPORT="$PY $ROOT/benches/bench_report.py"

case "$WHAT" in
    load | memory | render | shadow | emission | speed | all) ;;
    *) echo "usage: scripts/bench.sh [load|memory|render|shadow|emission|speed|all]" >&2; exit 2 ;;
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

# The large cloud's peak memory (target: 3x the density): the whole process against the density
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

# Pixel centres only (--antialias 1), as vdb_render samples them, in every murk row.
murk_render() { # OUT.exr STATS.json STEP SHADOWS [extra flags]
    local out=$1 stats=$2 step=$3 shadows=$4
    shift 4
    "$MURK" render "$CLOUD" -o "$out" --res "$RES" --eye "$EYE" --look-at "$LOOK" --fov "$FOV" \
        --sigma-a "$SIGMA_A,$SIGMA_A,$SIGMA_A" --sigma-s "$SIGMA_S,$SIGMA_S,$SIGMA_S" \
        --light "sun:$SUN:1,1,1:6" --step "$step" --shadows "$shadows" --shadow-step "$SHADOW_STEP" \
        --scattering single --float --stats "$stats" --quiet --threads "$THREADS" --antialias 1 "$@"
}

# murk choosing its own step, tolerance and termination for a relative radiance error of
# 1e-2 against its --reference: OUT.exr STATS.json. Single scattering, as
# vdb_render (murk's default adds the fast multiple-scattering lattice).
murk_render_budget() {
    "$MURK" render "$CLOUD" -o "$1" --res "$RES" --eye "$EYE" --look-at "$LOOK" --fov "$FOV" \
        --sigma-a "$SIGMA_A,$SIGMA_A,$SIGMA_A" --sigma-s "$SIGMA_S,$SIGMA_S,$SIGMA_S" \
        --light "sun:$SUN:1,1,1:6" --max-error 1e-2 --shadow-step "$SHADOW_STEP" \
        --scattering single --float --stats "$2" --quiet --threads "$THREADS" --antialias 1
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

# ------------------------------------------------------------------ E. speed
# The speed target. make_cloud.py's cloud fills the world cube [-4.8, 4.8]³ at every size.
SPEED_EYE=0,1,18
SPEED_LOOK=0,-0.4,0
SPEED_FOV=40
SPEED_SIGMA_A=1.92 # per world unit; vdb_render: × the voxel size
SPEED_SIGMA_S=5.76
SPEED_EXTENT=9.6

# murk on cloud N at RES: OUT.exr STATS.json CLOUD RES [flags]. Pixel centres only
# (--antialias 1), as vdb_render samples them, and so that a reference rendered at 1/3
# of the size has its pixel centres on the image's: murk's default resamples silhouette
# pixels on a 4x4 grid (+6 % CPU on the demo cloud at 640x360).
murk_speed() {
    local out=$1 stats=$2 vdb=$3 res=$4
    shift 4
    "$MURK" render "$vdb" -o "$out" --res "$res" --eye "$SPEED_EYE" --look-at "$SPEED_LOOK" --fov "$SPEED_FOV" \
        --sigma-a "$SPEED_SIGMA_A,$SPEED_SIGMA_A,$SPEED_SIGMA_A" --sigma-s "$SPEED_SIGMA_S,$SPEED_SIGMA_S,$SPEED_SIGMA_S" \
        --light "sun:$SUN:1,1,1:6" --float --stats "$stats" --quiet --threads "$THREADS" --antialias 1 "$@"
}

# vdb_render with its defaults (step 1, shadow step 3, cutoff 0.005): OUT.exr CLOUD RES VOXEL
vdb_speed() {
    local a s
    a=$($PY -c "print($SPEED_SIGMA_A * $4)")
    s=$($PY -c "print($SPEED_SIGMA_S * $4)")
    vdb_render "$2" "$1" -res "$3" -translate "$SPEED_EYE" -lookat "$SPEED_LOOK" -up 0,1,0 -fov "$SPEED_FOV" \
        -absorb "$a,$a,$a" -scatter "$s,$s,$s" -light "$SUN,1,1,1" -cpus "$THREADS" -v
}
export -f murk_speed vdb_speed

# Errors of IMAGE against the cloud's references, as JSON in $TMP/err.json: alpha against
# the full-size alpha reference, radiance against REF.exr (rendered at 1/SPEED_REF_SUB of
# the size, same camera: its pixel centres are IMAGE's), if given.
speed_err() { # IMAGE [REF.exr]
    $REPORT alpha "$1" "$TMP/test.fits"
    $REPORT alpha-error "$SREF/alpha.fits" "$TMP/test.fits" >"$TMP/err.json"
    if [[ -n "${2:-}" ]]; then
        local e
        e=$($REPORT rel-rmse "$2" "$1" "" "$SPEED_REF_SUB")
        $PY -c 'import json, sys; d = json.load(open(sys.argv[1])); d["radiance_rel_rmse"] = float(sys.argv[2]); json.dump(d, open(sys.argv[1], "w"))' \
            "$TMP/err.json" "$e"
    fi
}

bench_speed() {
    log "building murk (cargo build --release)"
    (cd "$ROOT" && cargo build --release --quiet)
    MURK="$ROOT/target/release/murk"
    local entry n res vdb voxel run name
    for entry in $SPEED_CLOUDS; do
        n=${entry%%:*} res=${entry#*:}
        vdb=${BENCH_SPEED_DIR:-$TMP}/cloud$n.vdb
        if [[ ! -f "$vdb" ]]; then
            log "writing the ${n}³ cloud"
            vdb=$TMP/cloud$n.vdb
            $PY "$ROOT/benches/make_cloud.py" "$vdb" --size "$n" >&2
        fi
        voxel=$($PY -c "print($SPEED_EXTENT / $n)")
        SREF=$TMP/speed-ref-$n
        mkdir -p "$SREF"
        if [[ -n "${BENCH_SPEED_REF_DIR:-}" && -f "$BENCH_SPEED_REF_DIR/speed-ref-$n/alpha.fits" ]]; then
            log "${n}³: references from $BENCH_SPEED_REF_DIR (not rendered again)"
            cp "$BENCH_SPEED_REF_DIR/speed-ref-$n/"* "$SREF/"
            cp "$BENCH_SPEED_REF_DIR"/results/speed-"$n"-ref-*.json "$OUT/" 2>/dev/null || true
        fi
        # Alpha needs no source step (optical depth is exact per voxel crossing at any
        # step) and no light: the whole image, shadows off, never terminated.
        if [[ ! -f "$SREF/alpha.fits" ]]; then
            log "${n}³ at $res: alpha reference, murk --shadows none --termination 0 (once)"
            TIME_TO="$TMP/time" LOG_TO="$TMP/murk.log" timed \
                murk_speed "$SREF/alpha.exr" "$TMP/stats.json" "$vdb" "$res" \
                --shadows none --termination 0 --scattering single --step "$SPEED_REF_STEP"
            $REPORT alpha "$SREF/alpha.exr" "$SREF/alpha.fits"
        fi
        # Radiance: murk's --reference (exact shadow rays per segment, no termination:
        # ~100× a default render) at 1/SPEED_REF_SUB of the size, every SPEED_REF_SUB-th
        # pixel of the image, its centre.
        local w=${res%x*} h=${res#*x}
        local ref_res=$((w / SPEED_REF_SUB))x$((h / SPEED_REF_SUB))
        local modes=single
        [[ "$SPEED_FAST_REF" == 1 ]] && modes="single fast"
        for mode in $modes; do
            [[ -f "$SREF/ref-$mode.exr" ]] && continue
            log "${n}³ at $ref_res: murk --reference --scattering $mode --step $SPEED_REF_STEP (once)"
            TIME_TO="$TMP/time" LOG_TO="$TMP/murk.log" timed \
                murk_speed "$SREF/ref-$mode.exr" "$TMP/stats.json" "$vdb" "$ref_res" \
                --reference --step "$SPEED_REF_STEP" --scattering "$mode"
            $REPORT run "$OUT/speed-$n-ref-$mode.1.json" --time "$TMP/time" --murk-stats "$TMP/stats.json"
        done
        for run in $(seq "$RUNS"); do
            name="speed-$n-vdb"
            log "${n}³ at $res: vdb_render (its defaults), run $run/$RUNS"
            TIME_TO="$TMP/time" LOG_TO="$TMP/vdb.log" timed vdb_speed "$TMP/speed.exr" "$vdb" "$res" "$voxel"
            speed_err "$TMP/speed.exr"
            $REPORT run "$OUT/$name.$run.json" --time "$TMP/time" --vdb-log "$TMP/vdb.log" --extra "$TMP/err.json"
            # case, radiance reference, murk's flags
            local rows=("maxerr-single|single|--max-error 1e-2 --scattering single"
                "maxerr-fast|fast|--max-error 1e-2"
                "default|fast|")
            local row key mode flags ref
            for row in "${rows[@]}"; do
                IFS='|' read -r key mode flags <<<"$row"
                ref=$SREF/ref-$mode.exr
                [[ -f "$ref" ]] || ref=
                name="speed-$n-$key"
                log "${n}³ at $res: murk ${flags:-(defaults)}, run $run/$RUNS"
                # shellcheck disable=SC2086 # the flags are words
                TIME_TO="$TMP/time" LOG_TO="$TMP/murk.log" timed \
                    murk_speed "$TMP/speed.exr" "$TMP/stats.json" "$vdb" "$res" $flags
                speed_err "$TMP/speed.exr" "$ref"
                $REPORT run "$OUT/$name.$run.json" --time "$TMP/time" --murk-stats "$TMP/stats.json" \
                    --extra "$TMP/err.json"
            done
        done
    done
}

if [[ "$WHAT" == load || "$WHAT" == all ]]; then bench_load; fi
if [[ "$WHAT" == load || "$WHAT" == memory || "$WHAT" == all ]]; then bench_memory; fi
if [[ "$WHAT" == render || "$WHAT" == all ]]; then bench_render; fi
if [[ "$WHAT" == shadow || "$WHAT" == all ]]; then bench_shadow; fi
if [[ "$WHAT" == emission || "$WHAT" == all ]]; then bench_emission; fi
if [[ "$WHAT" == speed || "$WHAT" == all ]]; then bench_speed; fi

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
 "speed_clouds": "$SPEED_CLOUDS", "speed_camera": "eye $SPEED_EYE, look-at $SPEED_LOOK, horizontal fov $SPEED_FOV°; σa $SPEED_SIGMA_A, σs $SPEED_SIGMA_S per world unit; sun $SUN (irradiance 6)",
 "speed_reference": "murk --reference --step $SPEED_REF_STEP at 1/$SPEED_REF_SUB of the size (the centre pixel of every $SPEED_REF_SUB×$SPEED_REF_SUB block)",
 "vdb_cutoff_default": "$VDB_CUTOFF_DEFAULT", "vdb_cutoff_matched": "$VDB_CUTOFF_MATCHED", "vdb_cutoff_tiny": "$VDB_CUTOFF_TINY"}
EOF
echo
$REPORT table "$OUT"
