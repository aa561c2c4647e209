#!/usr/bin/env bash
# murk --device gpu against --device cpu, side by side, per stage: the 192³ fBm cloud of
# benches/make_cloud.py at 960x540 with the camera, medium and sun of scripts/bench.sh's
# speed mode, with single scattering and with fast (the default: single scattering plus
# the multiple-scattering lattice gathered in the GPU's march). Under fast the lattice's
# sweeps run where MURK_GPU_LATTICE says: two more rows, gpu-fast-lattice-cpu (swept on
# the CPU, gathered on the GPU) and gpu-fast-lattice-gpu (swept on the GPU too), each with
# the lattice's solve seconds and where it was swept; gpu-fast is the automatic choice.
# Under single, gpu-single-bake-batch-large bakes the shadow map's light columns on the
# GPU in batches sixteen times the default (MURK_GPU_BAKE_BATCH): fewer, fuller dispatches;
# gpu-single-march-cut and -whole march shadow rays through the grid cut into parts
# (MURK_GPU_MAX_BINDING) and whole (not on an adapter that runs on the CPU), and
# gpu-single-map-cached and cpu-single-map-cached read the sun's map from a cache made
# once by `murk bake-shadows` (a look re-rendered after a camera move: no bake).
# Prints each run's wall and CPU seconds, the device and the stages of its --stats
# (gpu_upload: flattening and uploading the grid, maps and lattice; render: rays, march,
# readback and passes; multiple_scattering: the lattice's solve, of which gpu_lattice ran
# on the GPU), and per mode the image
# difference of the GPU's render against the CPU's (needs oiiotool). Then --scattering
# path at BENCH_PATH_SPP samples a pixel, on the GPU and on the CPU (all threads and
# one), with each one's paths per second (camera samples over the render stage) and the
# GPU's over the CPU's: the GPU traces the CPU's paths (the same random streams), so its
# noise at equal samples is the CPU's and that ratio is also the ratio of the times to
# a given error. Then a sequence (BENCH_SEQ_FRAMES copies of the cloud, fast) on the GPU
# and the CPU: the time of frame 1 and of frames 2..N a frame, and each frame's
# gpu_upload_bytes (0 where the scene's buffers stayed on the GPU).
#
#   scripts/bench_gpu.sh [CLOUD.vdb]    (made with make_cloud.py --size 192 if not given)
#
# Knobs: MURK (a murk binary; default: build this tree's), BENCH_THREADS (nproc),
# BENCH_MODES ("single fast": the scattering modes timed), BENCH_RES (960x540),
# BENCH_ONE_THREAD=0 (no one-thread CPU runs), BENCH_CUT=0 (no cut-grid rows),
# BENCH_PATH_RES (BENCH_RES), BENCH_PATH_SPP (16), BENCH_PATH=0 (no path runs),
# BENCH_SEQ=0 (no sequence), BENCH_SEQ_FRAMES (5), OUT (where images and stats go; a
# temporary folder).
# On a machine without a GPU it measures lavapipe (Mesa's Vulkan on the CPU), if installed.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
OUT=${OUT:-$(mktemp -d)}
THREADS=${BENCH_THREADS:-$(nproc)}
RES=${BENCH_RES:-960x540}
if [[ -z "${MURK:-}" ]]; then
    cargo build --release --quiet --manifest-path "$ROOT/Cargo.toml" --bin murk
    MURK=$ROOT/target/release/murk
fi
CLOUD=${1:-$OUT/cloud192.vdb}
[[ -f "$CLOUD" ]] || /usr/bin/python3 "$ROOT/benches/make_cloud.py" "$CLOUD" --size 192 >&2
A=(render "$CLOUD" --eye 0,1,18 --look-at 0,-0.4,0 --fov 40
   --sigma-a 1.92,1.92,1.92 --sigma-s 5.76,5.76,5.76 --light sun:0.6,1,0.5:1,1,1:6
   --float --quiet --antialias 1)
run() { # NAME FLAGS...
    local n=$1
    shift
    /usr/bin/time -f "$n: wall %e s, cpu %U+%S s" "$MURK" "${A[@]}" --res "${RUN_RES:-$RES}" -o "$OUT/$n.exr" \
        --stats "$OUT/$n.json" "$@" 2>&1 | tail -1
    /usr/bin/python3 -c "import json,sys; s=json.load(open(sys.argv[1])); print('  ', s['device'], {k: round(v['seconds'], 4) for k, v in s['stages'].items() if 'seconds' in v}); m=s.get('multiple_scattering'); m and print('   lattice', m['dims'], 'swept on', m['swept_on'], 'solve', round(m['solve_seconds'], 4), 's'); [print('   bake of', m['light'], {k.removesuffix('_seconds'): round(v, 4) for k, v in m.get('phases', {}).items()}) for m in s.get('shadow_maps', [])]; g=s['gpu_memory_bytes']; c=s['density_memory_bytes']+s['shadow_map_memory_bytes']; g and print(f'   GPU memory: the scene {g/1e6:.1f} MB ({g/max(c,1):.2f}x the CPU density and maps, {c/1e6:.1f} MB), the stream {s.get(\"gpu_stream_bytes\", 0)/1e6:.1f} MB')" "$OUT/$n.json"
}
MODES=(${BENCH_MODES:-single fast})
# Warm-up runs: a new process compiles each pipeline it uses (seconds on some drivers,
# kept on disk by them for the next), which no timed run should pay.
run warm --device gpu --scattering single >/dev/null
RUN_RES=64x36 run warm-fast --device gpu --scattering fast >/dev/null
[[ "${BENCH_PATH:-1}" == 0 ]] || RUN_RES=64x36 run warm-path --device gpu --scattering path --spp 1 >/dev/null
for mode in "${MODES[@]}"; do
    run "gpu-$mode" --device gpu --scattering $mode
    run "cpu-$mode" --device cpu --scattering $mode --threads "$THREADS"
    [[ "${BENCH_ONE_THREAD:-1}" == 0 ]] || run "cpu1-$mode" --device cpu --scattering $mode --threads 1
    if [[ $mode == single ]]; then
        # The bake's light columns in batches of 8 M samples against the default half
        # million: the same map, in fewer and fuller dispatches.
        MURK_GPU_BAKE_BATCH=8388608 run "gpu-single-bake-batch-large" --device gpu --scattering single
        # A re-render of a look whose map is already made (a camera move, a colour
        # change): the sun's map read from a cache `murk bake-shadows` wrote, so the
        # render is the upload, the march and the write, without the bake.
        "$MURK" bake-shadows "$CLOUD" -o "$OUT/shadows.vdb" "${A[@]:8:6}" --quiet
        run "gpu-single-map-cached" --device gpu --scattering single --shadow-cache "$OUT/shadows.vdb"
        run "cpu-single-map-cached" --device cpu --scattering single --threads "$THREADS" \
            --shadow-cache "$OUT/shadows.vdb"
        if [[ "${BENCH_CUT:-1}" != 0 ]]; then
            # The grid cut into parts (the largest binding lowered to 4 MiB: the values in
            # three buffers) against the same grid whole, with shadow rays marched through
            # it (the maps would not fit that binding). An adapter that runs on the CPU
            # refuses a cut grid under marched shadows: not timed there.
            adapter=$(/usr/bin/python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['device'])" \
                "$OUT/gpu-single.json")
            if [[ $adapter == *"(Cpu, "* ]]; then
                echo "gpu-single-march-cut: not timed ($adapter refuses a cut grid under --shadows march)"
            else
                run "gpu-single-march-whole" --device gpu --scattering single --shadows march
                MURK_GPU_MAX_BINDING=4194304 run "gpu-single-march-cut" --device gpu --scattering single --shadows march
                /usr/bin/python3 -c "import json,sys; p=[json.load(open(f))['gpu_grid_parts'] for f in sys.argv[1:]]
print('   grid parts (node tables, values): whole', p[0], 'cut', p[1])" \
                    "$OUT/gpu-single-march-whole.json" "$OUT/gpu-single-march-cut.json"
            fi
        fi
    fi
    if [[ $mode == fast ]]; then
        for where in cpu gpu; do
            MURK_GPU_LATTICE=$where run "gpu-fast-lattice-$where" --device gpu --scattering fast
        done
    fi
done
if command -v oiiotool >/dev/null; then
    avg() { oiiotool "$@" --printstats 2>&1 | awk '/Stats Avg/ {print $3, $6}'; }
    for mode in "${MODES[@]}" $([[ " ${MODES[*]} " == *" fast "* ]] && echo fast-lattice-gpu || true); do
        cpu=cpu-${mode%-lattice-gpu}
        # The difference × 1000 before squaring: --printstats prints six decimals.
        read -r d da < <(avg "$OUT/gpu-$mode.exr" "$OUT/$cpu.exr" --ch R,G,B,A --sub --mulc 1000 --dup --mul)
        read -r s _ < <(avg "$OUT/$cpu.exr" --ch R,G,B,A --dup --mul)
        /usr/bin/python3 -c "import math,sys; d,da,s=map(float,sys.argv[2:]); print(f'GPU against CPU, {sys.argv[1]}: radiance relative RMSE {math.sqrt(d/1e6/s):.2e}, alpha RMSE {math.sqrt(da/1e6):.2e}')" "$mode" "$d" "$da" "$s"
    done
fi
if [[ "${BENCH_PATH:-1}" != 0 ]]; then
    PRES=${BENCH_PATH_RES:-$RES}
    PSPP=${BENCH_PATH_SPP:-16}
    paths() { # NAME: paths per second over the render stage
        /usr/bin/python3 -c "import json,sys; s=json.load(open(sys.argv[1])); print(s['rays'] / s['stages']['render']['seconds'])" "$OUT/$1.json"
    }
    devs=(gpu cpu)
    [[ "${BENCH_ONE_THREAD:-1}" == 0 ]] || devs+=(cpu1)
    for dev in "${devs[@]}"; do
        case $dev in
            gpu) flags=(--device gpu) ;;
            cpu) flags=(--device cpu --threads "$THREADS") ;;
            cpu1) flags=(--device cpu --threads 1) ;;
        esac
        RUN_RES=$PRES run "$dev-path" "${flags[@]}" --scattering path --spp "$PSPP"
        echo "   $dev-path: $(paths "$dev-path") paths/s"
    done
    one=nan
    [[ "${BENCH_ONE_THREAD:-1}" == 0 ]] || one=$(paths cpu1-path)
    /usr/bin/python3 -c "import sys; g,c,c1=map(float,sys.argv[1:]); print(f'path at $PSPP spp, $PRES: GPU {g:.4g} paths/s, {g/c:.3g}x the CPU on $THREADS threads ({c:.4g}), {g/c1:.3g}x one thread ({c1:.4g})')" \
        "$(paths gpu-path)" "$(paths cpu-path)" "$one"
    if command -v oiiotool >/dev/null; then
        read -r d da < <(avg "$OUT/gpu-path.exr" "$OUT/cpu-path.exr" --ch R,G,B,A --sub --mulc 1000 --dup --mul)
        read -r s _ < <(avg "$OUT/cpu-path.exr" --ch R,G,B,A --dup --mul)
        /usr/bin/python3 -c "import math,sys; d,da,s=map(float,sys.argv[1:]); print(f'GPU against CPU, path: radiance relative RMSE {math.sqrt(d/1e6/s):.2e} (the same paths), alpha RMSE {math.sqrt(da/1e6):.2e}')" "$d" "$da" "$s"
    fi
fi
if [[ "${BENCH_SEQ:-1}" != 0 ]]; then
    # A sequence of BENCH_SEQ_FRAMES frames of the one cloud (copies), fast, on each
    # device: frames 2..N reuse the shadow maps, and on the GPU keep the scene's buffers
    # there (gpu_upload_bytes 0) while the next frame is read during the render.
    N=${BENCH_SEQ_FRAMES:-5}
    mkdir -p "$OUT/seq"
    for f in $(seq 1 "$N"); do cp "$CLOUD" "$OUT/seq/cloud_$(printf %04d "$f").vdb"; done
    for dev in gpu cpu; do
        /usr/bin/time -o "$OUT/seq/$dev.wall" -f %e "$MURK" render "$OUT/seq/cloud_####.vdb" \
            "${A[@]:2}" --res "$RES" --device $dev --threads "$THREADS" --frames "1-$N" \
            -o "$OUT/seq/$dev-####.exr" --stats "$OUT/seq/$dev-####.json"
        # Frames 2..N a frame: the run's wall time after frame 1's (a frame's own
        # total_seconds counts its preparing, which on the GPU overlaps the frame before).
        /usr/bin/python3 -c "
import json, sys
n, dev, out = int(sys.argv[1]), sys.argv[2], sys.argv[3]
st = [json.load(open(f'{out}/seq/{dev}-{f:04d}.json')) for f in range(1, n + 1)]
wall = float(open(f'{out}/seq/{dev}.wall').read().split()[-1])
first = st[0]['total_seconds']
print(f'seq-{dev}: {n} frames in {wall:.2f} s wall, frame 1 {first:.3f} s, frames 2..{n} {(wall - first) / max(n - 1, 1):.3f} s a frame; bytes uploaded per frame', [s.get('gpu_upload_bytes', 'n/a') for s in st])
" "$N" "$dev" "$OUT"
    done
fi
echo "images and stats in $OUT"
