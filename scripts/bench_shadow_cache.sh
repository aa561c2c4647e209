#!/usr/bin/env bash
# A look re-rendered from a shadow cache against the same render baking its map, in the
# same run: `murk bake-shadows` (its bake, its write, peak RSS), then `murk render
# --shadow-cache` and the same render baking (each one's shadows stage, whole-process
# total and peak RSS), and the ratio of the cached read to the bake. The 192³ fBm cloud
# of benches/make_cloud.py with the camera, medium and sun of bench_gpu.sh, single
# scattering; the image is small, as the map does not depend on it.
#
#   scripts/bench_shadow_cache.sh [CLOUD.vdb]   (made with make_cloud.py --size 192 if not given)
#
# Knobs: MURK (a murk binary; default: build this tree's), BENCH_RUNS (3), BENCH_RES
# (240x135), BENCH_THREADS (nproc), OUT (where files go; a temporary folder).
# Needs /usr/bin/time, and /usr/bin/python3 (with pyopenvdb to make the cloud).
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
OUT=${OUT:-$(mktemp -d)}
RUNS=${BENCH_RUNS:-3}
RES=${BENCH_RES:-240x135}
THREADS=${BENCH_THREADS:-$(nproc)}
if [[ -z "${MURK:-}" ]]; then
    cargo build --release --quiet --manifest-path "$ROOT/Cargo.toml" --bin murk
    MURK=$ROOT/target/release/murk
fi
CLOUD=${1:-$OUT/cloud192.vdb}
[[ -f "$CLOUD" ]] || /usr/bin/python3 "$ROOT/benches/make_cloud.py" "$CLOUD" --size 192 >&2
MAP=(--sigma-a 1.92,1.92,1.92 --sigma-s 5.76,5.76,5.76 --light sun:0.6,1,0.5:1,1,1:6
     --threads "$THREADS" --quiet)
VIEW=(--eye 0,1,18 --look-at 0,-0.4,0 --fov 40 --float --antialias 1 --scattering single
      --res "$RES")
timed() { # NAME COMMAND...: peak RSS and wall into $OUT/NAME.time
    local n=$1
    shift
    /usr/bin/time -o "$OUT/$n.time" -f '%e %M' "$@"
}
echo "| run | bake-shadows: bake s, write s, peak RSS MB | render from the cache: shadows s, total s, peak RSS MB | render baking: shadows s, total s, peak RSS MB | cache read / bake |"
echo "|---|---|---|---|---|"
for run in $(seq "$RUNS"); do
    timed bake "$MURK" bake-shadows "$CLOUD" -o "$OUT/shadows.vdb" "${MAP[@]}" --stats "$OUT/bake.json"
    timed cached "$MURK" render "$CLOUD" -o "$OUT/cached.exr" "${MAP[@]}" "${VIEW[@]}" \
        --shadow-cache "$OUT/shadows.vdb" --stats "$OUT/cached.json"
    timed baked "$MURK" render "$CLOUD" -o "$OUT/baked.exr" "${MAP[@]}" "${VIEW[@]}" --stats "$OUT/baked.json"
    /usr/bin/python3 - "$OUT" "$run" <<'EOF'
import json, sys
out, run = sys.argv[1], sys.argv[2]
s = {n: json.load(open(f"{out}/{n}.json")) for n in ("bake", "cached", "baked")}
rss = {n: int(open(f"{out}/{n}.time").read().split()[1]) / 1024 for n in s}
sec = lambda n, stage: s[n]["stages"][stage]["seconds"]
print(f"| {run} | {sec('bake', 'shadows'):.2f}, {sec('bake', 'write'):.2f}, {rss['bake']:.0f} "
      f"| {sec('cached', 'shadows'):.2f}, {s['cached']['total_seconds']:.2f}, {rss['cached']:.0f} "
      f"| {sec('baked', 'shadows'):.2f}, {s['baked']['total_seconds']:.2f}, {rss['baked']:.0f} "
      f"| {sec('cached', 'shadows') / sec('baked', 'shadows'):.2f} |")
EOF
done
echo "files in $OUT"
