#!/usr/bin/env bash
# Renders every fixture and the scenes the tests use with the murk of BASE_COMMIT and the
# murk of the working tree, as 32-bit float EXRs, and compares them pixel for pixel with
# OpenImageIO's idiff (exact: -fail 0) and their channel lists with exrheader.
#
#   scripts/same_images.sh BASE_COMMIT        # e.g. the commit before a refactor
#
# Exit 0 when every image is identical, 1 otherwise (each difference is printed).
# SAME_IMAGES_OLD_MURK: a murk already built at BASE_COMMIT (no worktree, no build).
# Needs idiff (openimageio-tools) and exrheader (openexr). Builds BASE_COMMIT in a
# temporary git worktree with its own target directory.
set -euo pipefail
base=${1:?usage: scripts/same_images.sh BASE_COMMIT}
root=$(cd "$(dirname "$0")/.." && pwd)
work=$(mktemp -d)
trap 'git -C "$root" worktree remove --force "$work/base" >/dev/null 2>&1 || true; rm -rf "$work"' EXIT
if [[ -n "${SAME_IMAGES_OLD_MURK:-}" ]]; then
  old=$SAME_IMAGES_OLD_MURK
  echo "building the working tree ($base: $old) ..." >&2
else
  git -C "$root" worktree add --detach "$work/base" "$base" >/dev/null
  echo "building $base and the working tree ..." >&2
  (cd "$work/base" && CARGO_TARGET_DIR="${SAME_IMAGES_BASE_TARGET:-$work/base/target}" cargo build --release -q)
  old="${SAME_IMAGES_BASE_TARGET:-$work/base/target}/release/murk"
fi
(cd "$root" && cargo build --release -q --bin murk)
new="$root/target/release/murk"
f="$root/fixtures"
# name | arguments (after INPUT -o OUT)
cases=(
  "cloud|$f/cloud.vdb|"
  "cloud_two_lights|$f/cloud.vdb|--light sun:1,1,0:1,0.9,0.8:8 --light point:2,3,1:0.3,0.4,1:40"
  "cloud_march|$f/cloud.vdb|--shadows march"
  "cloud_none|$f/cloud.vdb|--shadows none --spp 4 --seed 7"
  "cloud_ground|$f/cloud.vdb|--ground -1.2 --ground-visible"
  "cloud_ground_hidden|$f/cloud.vdb|--ground -1.2"
  "cloud_ortho_g|$f/cloud.vdb|--camera ortho --g 0.6 --sigma-a 0.1,0.2,0.3 --sigma-s 1,2,3"
  "cloud_reference|$f/cloud.vdb|--reference --res 48x27"
  "pyro|$f/pyro.vdb|"
  "pyro_emission_only|$f/pyro.vdb|--no-lights"
  "pyro_color_off|$f/pyro.vdb|--color-grid none --temperature-grid none"
  "levelset_fog|$f/levelset_fog.vdb|"
  "zip|$f/zip.vdb|"
  "rotated|$f/rotated.vdb|"
  "nonuniform|$f/nonuniform.vdb|"
  "far|$f/far.vdb|"
  "sphere|$f/sphere.vdb|--spp 2"
  "slab|$f/slab.vdb|--eye 0,0.5,5"
  "empty|$f/empty.vdb|"
  "scene|$f/scene.toml|"
)
fail=0
for c in "${cases[@]}"; do
  IFS='|' read -r name input args <<<"$c"
  case " $args " in *" --res "*) ;; *) args="$args --res 160x90" ;; esac
  for side in old new; do
    bin=${!side}
    # shellcheck disable=SC2086
    "$bin" render "$input" -o "$work/$side-$name.exr" --float --quiet $args
  done
  if ! idiff -fail 0 -failpercent 0 -warn 0 "$work/old-$name.exr" "$work/new-$name.exr" >"$work/idiff.txt" 2>&1; then
    echo "DIFFERENT: $name ($args)"; sed 's/^/    /' "$work/idiff.txt" | head -12; fail=1
  elif ! diff <(exrheader "$work/old-$name.exr" | grep -A40 '^channels' | grep -E '^\s+[A-Za-z_.]+, ') \
              <(exrheader "$work/new-$name.exr" | grep -A40 '^channels' | grep -E '^\s+[A-Za-z_.]+, ') >/dev/null; then
    echo "DIFFERENT CHANNELS: $name"; fail=1
  else
    echo "identical: $name"
  fi
done
exit $fail
