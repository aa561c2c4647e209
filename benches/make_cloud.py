#!/usr/bin/python3
"""Writes the sparse fBm clouds the cost-growth benchmark renders (made at run time).

    /usr/bin/python3 benches/make_cloud.py OUT.vdb --size N [--extent E]

One fog-volume grid `density`: the same cloud at every N (its shape is fixed in world
space, the cube [-E/2, E/2]³, default E = 9.6: voxel size E/N, 0.05 at N = 192), so
only the voxel count changes with N. The cloud is an ellipsoid roughened by five
octaves of value-noise fBm whose lattice is fixed in world units, cut at the value that
leaves 25 % of the box's voxels non-zero (1.77 M at N = 192, 27.6 M at N = 480: the
issue's 192³ and ≥ 25 M-voxel clouds), scaled to a peak density of 2.2. Only non-zero
voxels are active (tolerance 0), as a simulation cache writes them.

Prints one JSON line: path, size, voxel size, active voxels, file bytes.
Needs Debian's python3-openvdb and python3-numpy (/usr/bin/python3).
"""

import argparse
import json
import os
import sys

import numpy as np
import pyopenvdb as vdb

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from make_big_grid import value_noise  # noqa: E402  (the same noise as the load benchmark)

ACTIVE_FRACTION = 0.25
PEAK = 2.2


def make_cloud(n, seed=7):
    rng = np.random.default_rng(seed)
    fbm = np.zeros((n, n, n), dtype=np.float32)
    amp = 0.5
    for octave in range(5):
        fbm += amp * value_noise(n, 3 << octave, rng)
        amp *= 0.5
    # An ellipsoid, wider than tall, centred a little low, as a cumulus block.
    u = np.linspace(-1.0, 1.0, n, dtype=np.float32)
    x = u[:, None, None] / 0.95
    y = (u[None, :, None] + 0.1) / 0.7
    z = u[None, None, :] / 0.9
    shape = 1.0 - (x * x + y * y + z * z)
    field = shape + 0.9 * fbm
    del fbm, shape
    # The cut: the (1 - ACTIVE_FRACTION) quantile, from a strided subsample (exact
    # enough, and cheap at 480³).
    cut = float(np.quantile(field[::3, ::3, ::3], 1.0 - ACTIVE_FRACTION))
    field -= cut
    np.clip(field, 0.0, None, out=field)
    field *= PEAK / float(field.max())
    return field


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out")
    ap.add_argument("--size", type=int, required=True)
    ap.add_argument("--extent", type=float, default=9.6)
    ap.add_argument("--seed", type=int, default=7, help="the noise's seed (7: the benchmark's cloud)")
    args = ap.parse_args()
    if args.size < 16 or args.size > 1024:
        sys.exit("--size must be in 16..1024")
    dens = make_cloud(args.size, args.seed)
    g = vdb.FloatGrid(0.0)
    lo = (-(args.size // 2),) * 3
    g.copyFromArray(dens, lo, 0.0)
    del dens
    g.name = "density"
    g.gridClass = vdb.GridClass.FOG_VOLUME
    voxel = args.extent / args.size
    g.transform = vdb.createLinearTransform(voxel)
    vdb.write(args.out, [g])
    print(json.dumps({
        "path": args.out, "size": args.size, "voxel_size": voxel,
        "active_voxels": int(g.activeVoxelCount()), "file_bytes": os.path.getsize(args.out),
    }))


if __name__ == "__main__":
    main()
