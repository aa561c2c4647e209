#!/usr/bin/python3
"""Copies a grid with its active topology dilated by one voxel (values unchanged).

    /usr/bin/python3 benches/dilate_topology.py IN.vdb GRID OUT.vdb

Every voxel next to an active one (26-neighbourhood) is switched on with the value it
already had (normally the background). The field — and any correct render of it — is
unchanged. vdb_render only integrates inside active leaf nodes (its VolumeRayIntersector
does no dilation), so it misses the trilinear ramp in the one-voxel layer below a leaf
whose neighbour is absent; on the dilated copy it does not. scripts/bench.sh renders both
to show that this, and not a unit convention, is what separates vdb_render's alpha from
murk's.
"""

import sys

import pyopenvdb as vdb


def main():
    src, name, dst = sys.argv[1:4]
    grid = vdb.read(src, name)
    acc = grid.getAccessor()
    active = [(it.min, it.count) for it in grid.citerOnValues()]
    if any(count != 1 for _, count in active):
        sys.exit("dilate_topology.py: active tiles are not supported")
    voxels = [ijk for ijk, _ in active]
    seen = set(voxels)
    for i, j, k in voxels:
        for di in (-1, 0, 1):
            for dj in (-1, 0, 1):
                for dk in (-1, 0, 1):
                    c = (i + di, j + dj, k + dk)
                    if c not in seen:
                        seen.add(c)
                        acc.setValueOn(c, acc.getValue(c))
    vdb.write(dst, [grid])


if __name__ == "__main__":
    main()
