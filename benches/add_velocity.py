#!/usr/bin/python3
"""Adds a synthetic velocity to a cloud of benches/make_cloud.py, for the motion blur benchmark.

    /usr/bin/python3 benches/add_velocity.py IN.vdb OUT.vdb [--speed S] [--coarse K]

Writes IN's grids and a vec3 grid `vel` (world units a second, as Houdini writes it): a
swirl about the vertical (y) axis through the box's centre plus a drift along +x, the
speed at the box's edge S (default 24: a 180° shutter at 24 fps moves the edge half a
world unit, 10 voxels of the 192³ cloud), on voxels K times the density's (default 2:
simulations often store velocity coarser), over the density's box grown by a quarter, as a
simulation writes velocity beyond the smoke.
Needs Debian's python3-openvdb and python3-numpy (/usr/bin/python3).
"""

import argparse

import numpy as np
import pyopenvdb as vdb


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("inp")
    ap.add_argument("out")
    ap.add_argument("--speed", type=float, default=24.0)
    ap.add_argument("--coarse", type=int, default=2)
    a = ap.parse_args()
    grids = vdb.readAll(a.inp)[0]
    density = next(g for g in grids if g.name == "density")
    (i0, j0, k0), (i1, j1, k1) = density.evalActiveVoxelBoundingBox()
    voxel = density.transform.voxelSize()[0]
    lo = np.array(density.transform.indexToWorld((i0, j0, k0)))
    hi = np.array(density.transform.indexToWorld((i1, j1, k1)))
    centre, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    size = voxel * a.coarse
    glo, ghi = centre - 1.25 * half, centre + 1.25 * half
    n = np.maximum(np.ceil((ghi - glo) / size).astype(int), 1)
    i = np.floor(glo / size).astype(int)
    axes = [(i[c] + np.arange(n[c])) * size for c in range(3)]
    x, y, z = np.meshgrid(*axes, indexing="ij")
    r = max(half[0], half[2])
    w = 0.5 * a.speed / r  # the swirl's angular speed: half the speed at the edge
    vel = np.zeros(tuple(n) + (3,), dtype=np.float32)
    vel[..., 0] = -w * (z - centre[2]) + 0.5 * a.speed
    vel[..., 2] = w * (x - centre[0])
    v = vdb.Vec3SGrid()
    v.name = "vel"
    v.copyFromArray(vel, ijk=tuple(int(c) for c in i))
    v.transform = vdb.createLinearTransform(size)
    vdb.write(a.out, grids=grids + [v])


if __name__ == "__main__":
    main()
