#!/usr/bin/python3
"""Cache-like fixtures: OpenVDB files laid out the way Blender's Mantaflow writes its
caches, a plume with no tool's marks, a level set and a short smoke sequence, for
tests/real_caches.rs.

Usage:
    /usr/bin/python3 scripts/cache_fixtures.py fixtures/caches

Mantaflow (Blender's fluid solver) writes one .vdb per frame with the grids `density`,
`shadow` (its own light attenuation), `temperature`, `flame` and a staggered `velocity`
(vec3s, grid class `staggered`, vector type `contravariant relative`: a MAC grid), no
`creator` metadata, and, for plain smoke, `color_r/g/b` grids with no active voxel
(background 0). Blender is Z-up: the plume rises along +z.

- mantaflow_fire.vdb: a fire frame without colour grids: `flame` 0..1 at the source,
  `temperature` 0..2.
- mantaflow_smoke.vdb: a smoke-only frame: `flame` with no active voxel, `temperature`
  1..2 at the source, and empty `color_r/g/b`.
- plume_zup.vdb: `density` and `temperature` only, no metadata, rising along +z (what a
  pyopenvdb script writes): no tool to tell the up axis, the data tells it.
- levelset_sphere.vdb: `pyopenvdb.createLevelSetSphere` (radius 1, voxel 0.05), named
  `density`: a level set, not a fog volume.
- smoke_seq/smoke_0001..0012.vdb: a Mantaflow smoke sequence whose plume rises from the
  floor of its domain and grows over the frames.

Deterministic: only the UUIDs in the files change between runs.
"""
import os
import sys

import numpy as np
import pyopenvdb as vdb

FOG = vdb.GridClass.FOG_VOLUME
VOXEL = 0.05


def _coords(lo, hi):
    axes = [np.arange(a, b + 1, dtype=np.float64) for a, b in zip(lo, hi)]
    return np.meshgrid(*axes, indexing="ij")


def _grid(name, arr, lo, xf, cls=FOG):
    vec = arr.ndim == 4
    g = vdb.Vec3SGrid() if vec else vdb.FloatGrid()
    tol = (0.0, 0.0, 0.0) if vec else 0.0
    g.copyFromArray(np.ascontiguousarray(arr, dtype=np.float32), tuple(lo), tol)
    g.name, g.transform, g.gridClass = name, xf, cls
    return g


def _empty(name, xf):
    g = vdb.FloatGrid()
    g.name, g.transform, g.gridClass = name, xf, FOG
    return g


def _velocity(vz, lo, xf):
    """Mantaflow's MAC velocity: vec3s, staggered, contravariant relative."""
    v = np.stack([0.0 * vz, 0.0 * vz, vz], axis=-1)
    g = _grid("velocity", v, lo, xf, cls=vdb.GridClass.STAGGERED)
    g.vectorType = vdb.VectorType.CONTRAVARIANT_RELATIVE
    return g


def _plume(lo, hi, top):
    """A plume rising along +z from the floor of the box lo..hi up to height fraction
    `top` of the box: density, heat (1 at the source, falling with height) and the
    height fraction."""
    x, y, z = _coords(lo, hi)
    span = [float(b - a) for a, b in zip(lo, hi)]
    cx, cy = (lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0
    h = (z - lo[2]) / span[2]
    r2 = ((x - cx) / (0.5 * span[0])) ** 2 + ((y - cy) / (0.5 * span[1])) ** 2
    radius = 0.25 + 0.5 * np.clip(h / max(top, 1e-6), 0.0, 1.0)
    q = np.maximum(1.0 - r2 / (radius * radius), 0.0)
    inside = h <= top
    dens = np.where(inside, q * (4.0 - 2.0 * h / max(top, 1e-6)), 0.0)
    heat = np.where(inside, q * np.clip(1.0 - 3.0 * h, 0.0, 1.0), 0.0)
    return dens, heat, h


def mantaflow_fire():
    lo, hi = (0, 0, 0), (23, 23, 39)
    xf = vdb.createLinearTransform(VOXEL)
    dens, heat, _ = _plume(lo, hi, 0.9)
    return [_grid("density", dens, lo, xf),
            _grid("shadow", np.where(dens > 0, np.exp(-dens), 0.0), lo, xf),
            _grid("temperature", 2.0 * heat, lo, xf),
            _grid("flame", np.clip(1.6 * heat - 0.2, 0.0, 1.0), lo, xf),
            _velocity(np.where(dens > 0, 0.5 + heat, 0.0), lo, xf)]


def mantaflow_smoke(top=0.9, lo=(0, 0, 0), hi=(23, 23, 39)):
    xf = vdb.createLinearTransform(VOXEL)
    dens, heat, _ = _plume(lo, hi, top)
    temp = np.where(heat > 0.0, 1.0 + heat, 0.0)          # 1..2 at the source
    return [_grid("density", dens, lo, xf),
            _grid("shadow", np.where(dens > 0, np.exp(-dens), 0.0), lo, xf),
            _grid("temperature", temp, lo, xf),
            _empty("flame", xf),
            _velocity(np.where(dens > 0, 0.5 + heat, 0.0), lo, xf),
            _empty("color_r", xf), _empty("color_g", xf), _empty("color_b", xf)]


def plume_zup():
    lo, hi = (0, 0, 0), (23, 23, 39)
    xf = vdb.createLinearTransform(VOXEL)
    dens, heat, _ = _plume(lo, hi, 0.9)
    return [_grid("density", dens, lo, xf), _grid("temperature", 1.5 * heat, lo, xf)]


def levelset_sphere():
    g = vdb.createLevelSetSphere(radius=1.0, center=(0, 0, 0), voxelSize=VOXEL,
                                 halfWidth=3.0)
    g.name = "density"
    return [g]


SEQUENCE = range(1, 13)


def generate(out):
    os.makedirs(os.path.join(out, "smoke_seq"), exist_ok=True)
    w = lambda name, grids: vdb.write(os.path.join(out, name), grids)
    w("mantaflow_fire.vdb", mantaflow_fire())
    w("mantaflow_smoke.vdb", mantaflow_smoke())
    w("plume_zup.vdb", plume_zup())
    w("levelset_sphere.vdb", levelset_sphere())
    # A domain twice as tall as the final plume's width, the plume growing from a
    # tenth of it to nine tenths.
    for f in SEQUENCE:
        top = 0.1 + 0.8 * (f - 1) / (len(SEQUENCE) - 1)
        w("smoke_seq/smoke_%04d.vdb" % f, mantaflow_smoke(top, hi=(19, 19, 47)))


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    generate(sys.argv[1])
