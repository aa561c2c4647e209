#!/usr/bin/env bash
# The mesh benchmark: tetrahedra crossed per second per thread on a ≥ 1 M-cell mesh,
# and the same density resampled to a VDB grid rendered for comparison.
#
#   scripts/bench_mesh.sh            (about a minute; not part of the tests)
#
# 1. benches/make_mesh.py (meshio, vtk, pyopenvdb in /opt/murk-venv) writes a jittered
#    Kuhn tet mesh of the unit cube, BENCH_MESH_N³ cubes × 6 (N = 56: 1,053,696
#    tetrahedra) with a smooth point-data density, as .vtu; and the density resampled by
#    vtkProbeFilter at voxel size 1/(2N) as .vdb.
# 2. benches/mesh.rs loads both, walks BENCH_MESH_RAYS random rays on one thread
#    (tetrahedra crossed per second, with and without integrating the density), renders
#    the alpha of each at BENCH_MESH_RES² through the library's march on one thread and
#    on all, and compares the two images.
# Prints the JSON line and a markdown table. BENCH_KEEP=1 keeps the temporary directory
# (mesh.vtu, mesh.vdb, mesh_alpha.png, vdb_alpha.png).
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
N=${BENCH_MESH_N:-56}
RES=${BENCH_MESH_RES:-256}
RAYS=${BENCH_MESH_RAYS:-20000}
PY=${MURK_VENV_PYTHON:-/opt/murk-venv/bin/python}
TMP=$(mktemp -d /tmp/murk_bench_mesh.XXXXXX)
[ "${BENCH_KEEP:-0}" = 1 ] || trap 'rm -rf "$TMP"' EXIT
"$PY" "$ROOT/benches/make_mesh.py" "$N" "$TMP/mesh.vtu" "$TMP/mesh.vdb" >&2
JSON=$(cd "$ROOT" && cargo bench -q --bench mesh -- "$TMP/mesh.vtu" "$TMP/mesh.vdb" \
  --res "$RES" --rays "$RAYS" --out "$TMP" 2>/dev/null | grep '^{')
echo "$JSON"
"$PY" - "$JSON" <<'PY'
import json, sys
r = json.loads(sys.argv[1])
M = 1e6
print()
print("| %s tetrahedra (%.0f MB) vs VDB %d voxels (%.1f MB) | mesh | VDB |" % (
    format(r["tetrahedra"], ","), r["mesh_memory_bytes"] / M, r["vdb_active_voxels"], r["vdb_memory_bytes"] / M))
print("|---|---|---|")
print("| load (s) | %.2f | %.3f |" % (r["mesh_load_s"], r["vdb_load_s"]))
print("| walk, tetrahedra crossed / s / thread | %.2f M | |" % (r["walk_cells_per_s_1_thread"] / M))
print("| walk + ∫ρ, tetrahedra / s / thread | %.2f M | |" % (r["integrate_cells_per_s_1_thread"] / M))
print("| render %d² alpha, 1 thread (s) | %.2f | %.2f |" % (r["render_res"], r["mesh_render_s_1_thread"], r["vdb_render_s_1_thread"]))
print("| render %d² alpha, %d threads (s) | %.2f | %.2f |" % (r["render_res"], r["threads"], r["mesh_render_s_all"], r["vdb_render_s_all"]))
print("| alpha difference mesh − VDB: mean / RMS / max | %.1e / %.1e / %.1e | |" % (
    r["alpha_diff_mean"], r["alpha_diff_rms"], r["alpha_diff_max"]))
PY
