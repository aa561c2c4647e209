#!/usr/bin/env bash
# murk --device gpu against --device cpu, side by side, per stage: the 192³ fBm cloud of
# benches/make_cloud.py at 960x540 with the camera, medium and sun of scripts/bench.sh's
# speed mode, with single scattering and with fast (the default: single scattering plus
# the multiple-scattering lattice, solved on the CPU and gathered in the GPU's march).
# Prints each run's wall and CPU seconds, the device and the stages of its --stats
# (gpu_upload: flattening and uploading the grid, maps and lattice; render: rays, march,
# readback and passes; multiple_scattering: the lattice's solve), and per mode the image
# difference of the GPU's render against the CPU's (needs oiiotool).
#
#   scripts/bench_gpu.sh [CLOUD.vdb]    (made with make_cloud.py --size 192 if not given)
#
# Knobs: MURK (a murk binary; default: build this tree's), BENCH_THREADS (nproc),
# BENCH_RES (960x540), OUT (where images and stats go; a temporary folder).
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
A=(render "$CLOUD" --res "$RES" --eye 0,1,18 --look-at 0,-0.4,0 --fov 40
   --sigma-a 1.92,1.92,1.92 --sigma-s 5.76,5.76,5.76 --light sun:0.6,1,0.5:1,1,1:6
   --float --quiet --antialias 1)
run() { # NAME FLAGS...
    local n=$1
    shift
    /usr/bin/time -f "$n: wall %e s, cpu %U+%S s" "$MURK" "${A[@]}" -o "$OUT/$n.exr" \
        --stats "$OUT/$n.json" "$@" 2>&1 | tail -1
    /usr/bin/python3 -c "import json,sys; s=json.load(open(sys.argv[1])); print('  ', s['device'], {k: round(v['seconds'], 4) for k, v in s['stages'].items() if 'seconds' in v})" "$OUT/$n.json"
}
run warm --device gpu --scattering single >/dev/null
for mode in single fast; do
    run "gpu-$mode" --device gpu --scattering $mode
    run "cpu-$mode" --device cpu --scattering $mode --threads "$THREADS"
    run "cpu1-$mode" --device cpu --scattering $mode --threads 1
done
if command -v oiiotool >/dev/null; then
    avg() { oiiotool "$@" --printstats 2>&1 | awk '/Stats Avg/ {print $3, $6}'; }
    for mode in single fast; do
        # The difference × 1000 before squaring: --printstats prints six decimals.
        read -r d da < <(avg "$OUT/gpu-$mode.exr" "$OUT/cpu-$mode.exr" --ch R,G,B,A --sub --mulc 1000 --dup --mul)
        read -r s _ < <(avg "$OUT/cpu-$mode.exr" --ch R,G,B,A --dup --mul)
        /usr/bin/python3 -c "import math,sys; d,da,s=map(float,sys.argv[2:]); print(f'GPU against CPU, {sys.argv[1]}: radiance relative RMSE {math.sqrt(d/1e6/s):.2e}, alpha RMSE {math.sqrt(da/1e6):.2e}')" "$mode" "$d" "$da" "$s"
    done
fi
echo "images and stats in $OUT"
