#!/usr/bin/env bash
# A session on a machine with a real GPU but no Rust toolchain, in two steps.
#
#   scripts/gpu_session.sh pack    here: builds murk and the GPU test binary (release),
#                                  strips and packs them with the 192³ benchmark cloud
#                                  into .bench/ (about 15 MB: carry it with the tree)
#   scripts/gpu_session.sh run     there, in the repository root: the GPU test suite on
#                                  the machine's own GPU (MURK_TEST_GPU=system), then
#                                  scripts/bench_gpu.sh; logs and images go to $OUT
#
# On a machine without a Vulkan loader, put Debian's loader packages in .gl/ (see the
# benchmark docs) and carry it too: `run` unpacks them first and, where the NVIDIA
# driver's Vulkan manifest is found, points the loader at it.
# Knobs for `run`: SUITE=0 (no test suite), BENCH=0 (no benchmark), TEST_FILTER (names
# of the suite's tests to run: all by default), and bench_gpu.sh's own.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
PACK=$ROOT/.bench
case "${1:-}" in
pack)
    mkdir -p "$PACK"
    cargo build --release --quiet --manifest-path "$ROOT/Cargo.toml" --bin murk
    binary=$(cargo test --release --manifest-path "$ROOT/Cargo.toml" --test gpu --no-run \
        --message-format=json 2>/dev/null |
        /usr/bin/python3 -c 'import json,sys
for l in sys.stdin:
    m = json.loads(l)
    if m.get("reason") == "compiler-artifact" and m["target"]["name"] == "gpu" and m.get("executable"):
        print(m["executable"])')
    strip -o "$PACK/murk" "$ROOT/target/release/murk"
    strip -o "$PACK/gpu-tests" "$binary"
    gzip -f "$PACK/murk" "$PACK/gpu-tests"
    # The test binary finds fixtures, murk and its scratch folders where it was built.
    echo "$ROOT" > "$PACK/built-in"
    [[ -f "$PACK/cloud192.vdb" ]] ||
        /usr/bin/python3 "$ROOT/benches/make_cloud.py" "$PACK/cloud192.vdb" --size 192 >&2
    du -sh "$PACK"
    ;;
run)
    OUT=${OUT:-$(mktemp -d)}
    mkdir -p "$OUT"
    if compgen -G "$ROOT/.gl/*.deb" >/dev/null; then
        for f in "$ROOT"/.gl/*.deb; do dpkg -x "$f" /; done
        ldconfig
    fi
    nvidia=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
    [[ -n "${VK_DRIVER_FILES:-}" || ! -f "$nvidia" ]] || export VK_DRIVER_FILES=$nvidia
    export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-$(mktemp -d)}
    gunzip -kf "$PACK/murk.gz" "$PACK/gpu-tests.gz"
    chmod +x "$PACK/murk" "$PACK/gpu-tests"
    built=$(cat "$PACK/built-in")
    if [[ "$built" != "$ROOT" && ! -e "$built" ]]; then
        mkdir -p "$(dirname "$built")"
        ln -s "$ROOT" "$built"
    fi
    mkdir -p "$ROOT/target/release" "$ROOT/target/tmp"
    cp "$PACK/murk" "$ROOT/target/release/murk"
    nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv 2>/dev/null || true
    if [[ "${SUITE:-1}" != 0 ]]; then
        # shellcheck disable=SC2086
        (cd "$ROOT" && MURK_TEST_GPU=system "$PACK/gpu-tests" --test-threads 1 ${TEST_FILTER:-}) \
            2>&1 | tee "$OUT/gpu-tests.log" | grep -E "^test |test result|panicked" || true
    fi
    if [[ "${BENCH:-1}" != 0 ]]; then
        mkdir -p "$OUT/bench"
        OUT=$OUT/bench MURK=$PACK/murk "$ROOT/scripts/bench_gpu.sh" "$PACK/cloud192.vdb" \
            2>&1 | tee "$OUT/bench.log"
    fi
    ;;
*)
    echo "usage: scripts/gpu_session.sh pack|run" >&2
    exit 2
    ;;
esac
