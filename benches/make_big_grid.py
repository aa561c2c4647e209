#!/usr/bin/python3
"""Writes the large grid the "load" benchmark reads (not committed; made at run time).

    /usr/bin/python3 benches/make_big_grid.py OUT_DIR [--size N]

Writes OUT_DIR/big_float.vdb and OUT_DIR/big_half.vdb: one fog-volume grid `density`,
N³ voxels (default 264³ ≈ 18.4 M), every voxel active. The values are a few octaves of
value-noise fBm under a soft box falloff, kept in (0.001, ~1.5], so nothing is pruned
into tiles. pyopenvdb writes with its default codec (blosc when OpenVDB was built with
it, as Debian's is). The `half` file is the same grid saved as 16-bit floats.

Needs Debian's python3-openvdb and python3-numpy (/usr/bin/python3).
"""

import argparse
import os
import sys

import numpy as np
import pyopenvdb as vdb


def upsample_axis(a, axis, n_out):
    """Linear interpolation of `a` along `axis` from its lattice to `n_out` samples."""
    n_in = a.shape[axis]
    x = np.arange(n_out, dtype=np.float32) * ((n_in - 1) / n_out)
    i0 = np.minimum(x.astype(np.int64), n_in - 2)
    w = (x - i0).astype(np.float32)
    shape = [1, 1, 1]
    shape[axis] = n_out
    w = w.reshape(shape)
    lo = np.take(a, i0, axis=axis)
    hi = np.take(a, i0 + 1, axis=axis)
    return lo + (hi - lo) * w


def value_noise(n, cells, rng):
    """Trilinear value noise in [-1, 1] on an n³ grid with `cells` lattice cells per side."""
    lattice = rng.uniform(-1.0, 1.0, size=(cells + 1,) * 3).astype(np.float32)
    out = lattice
    for axis in range(3):
        out = upsample_axis(out, axis, n)
    return out


def make_density(n, seed=7):
    rng = np.random.default_rng(seed)
    fbm = np.zeros((n, n, n), dtype=np.float32)
    amp = 0.5
    for octave in range(5):
        fbm += amp * value_noise(n, 4 << octave, rng)
        amp *= 0.5
    # Soft falloff towards the faces of the box, so the grid looks like a cloud block.
    u = np.abs(np.linspace(-1.0, 1.0, n, dtype=np.float32))
    edge = np.clip((1.0 - u) * 6.0, 0.0, 1.0)
    fall = edge[:, None, None] * edge[None, :, None] * edge[None, None, :]
    dens = (0.6 + fbm) * fall
    np.clip(dens, 0.001, None, out=dens)
    return dens


def write_grid(path, dens, half):
    g = vdb.FloatGrid(0.0)
    n = dens.shape[0]
    lo = (-(n // 2), -(n // 2), -(n // 2))
    # Tolerance 0: every voxel differs from the background, so all are active.
    g.copyFromArray(dens, lo, 0.0)
    g.name = "density"
    g.gridClass = vdb.GridClass.FOG_VOLUME
    g.transform = vdb.createLinearTransform(0.05)
    g.saveFloatAsHalf = half
    vdb.write(path, [g])
    return g.activeVoxelCount()


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out_dir")
    ap.add_argument("--size", type=int, default=264)
    args = ap.parse_args()
    if args.size < 16:
        sys.exit("--size must be at least 16")
    os.makedirs(args.out_dir, exist_ok=True)
    dens = make_density(args.size)
    for name, half in (("big_float.vdb", False), ("big_half.vdb", True)):
        path = os.path.join(args.out_dir, name)
        count = write_grid(path, dens, half)
        print(f"{path}: {count} active voxels, {os.path.getsize(path) / 2**20:.1f} MiB")


if __name__ == "__main__":
    main()
