"""Fixtures in the conventions of the tools production caches come from (imported by
make_fixtures.py, which owns the reference): a Blender Mantaflow-style frame, a Houdini
pyro-style frame and a dense all-active grid holding a small plume.

- blender_smoke.vdb: Z up (the plume rises along +z), temperature normalised 0..1
  (ambient 0, as Mantaflow writes it), colour as three float grids color_r/g/b, and an
  all-zero `flame` grid whose voxels are active (a smoke-only frame of a fire domain).
- houdini_pyro.vdb: Y up, temperature 0..2 (ambient 0), flame 0..1, Cd and vel vec3,
  file metadata creator = "Houdini/SOP_OpenVDB_Write" (what Houdini's OpenVDB Write SOP
  stamps on its files).
- dense_plume.vdb: a 128x64x64 grid whose voxels are all active (an exported dense
  domain: active tiles of 0 everywhere) with a small plume near one corner, Y up.
"""
import numpy as np
import pyopenvdb as vdb

FOG = vdb.GridClass.FOG_VOLUME


def _coords(lo, hi):
    axes = [np.arange(a, b + 1, dtype=np.float64) for a, b in zip(lo, hi)]
    return np.meshgrid(*axes, indexing="ij")


def _grid(name, arr, lo, xf, cls=FOG):
    g = vdb.Vec3SGrid() if arr.ndim == 4 else vdb.FloatGrid()
    tol = (0.0, 0.0, 0.0) if arr.ndim == 4 else 0.0
    g.copyFromArray(np.ascontiguousarray(arr, dtype=np.float32), tuple(lo), tol)
    g.name, g.transform = name, xf
    if cls is not None:
        g.gridClass = cls
    return g


def _plume(lo, hi, up):
    """A plume rising along axis `up` (0, 1 or 2) from the box's floor: density, a
    normalised heat in 0..1 and the height fraction, on the box lo..hi."""
    c = _coords(lo, hi)
    span = [float(b - a) for a, b in zip(lo, hi)]
    mid = [(a + b) / 2.0 for a, b in zip(lo, hi)]
    h = (c[up] - lo[up]) / span[up]                      # 0 at the floor, 1 at the top
    across = [a for a in range(3) if a != up]
    r2 = sum(((c[a] - mid[a]) / (0.5 * span[a])) ** 2 for a in across)
    radius = 0.35 + 0.45 * h
    q = np.maximum(1.0 - r2 / (radius * radius), 0.0)
    dens = np.clip(q * (1.0 - h) * 1.6, 0.0, None) * (h < 0.95)
    heat = np.clip(q * (1.0 - h) ** 2 * 1.4, 0.0, 1.0)
    return dens, heat, h


def make_blender():
    lo, hi = (0, 0, 0), (23, 23, 39)                  # z up: taller along z
    xf = vdb.createLinearTransform(0.05)
    dens, heat, h = _plume(lo, hi, up=2)
    mask = dens > 0.0
    temp = np.where(mask | (heat > 0.0), heat, 0.0)     # normalised, ambient 0, max 1
    flame = vdb.FloatGrid()                            # all zero, all active
    flame.name, flame.gridClass, flame.transform = "flame", FOG, xf
    flame.fill(lo, hi, 0.0, True)
    grids = [_grid("density", dens, lo, xf), flame, _grid("temperature", temp, lo, xf)]
    for name, val in (("color_r", 0.9), ("color_g", 0.5), ("color_b", 0.2)):
        grids.append(_grid(name, np.where(mask, val + 0.1 * h, 0.0), lo, xf))
    return grids


def make_houdini():
    lo, hi = (-12, 0, -12), (11, 35, 11)               # y up
    xf = vdb.createLinearTransform(0.05)
    dens, heat, h = _plume(lo, hi, up=1)
    mask = dens > 0.0
    temp = np.where(mask, 2.0 * heat, 0.0)             # Houdini pyro: ~0..2, ambient 0
    flame = np.where(mask, np.clip(2.0 * heat - 0.6, 0.0, 1.0), 0.0)
    cd = np.stack([0.8 + 0.0 * h, 0.6 + 0.2 * h, 0.4 + 0.4 * h], axis=-1) * mask[..., None]
    vel = np.stack([0.0 * h, 1.0 + heat, 0.0 * h], axis=-1) * mask[..., None]
    return [_grid("density", dens, lo, xf), _grid("temperature", temp, lo, xf),
            _grid("flame", flame, lo, xf), _half(_grid("Cd", cd, lo, xf, cls=None)),
            _half(_grid("vel", vel, lo, xf, cls=None))]


def _half(g):
    g.saveFloatAsHalf = True
    return g


HOUDINI_METADATA = {"creator": "Houdini/SOP_OpenVDB_Write"}


def make_dense():
    """128x64x64 voxels all active (0 everywhere but a plume of radius 5 voxels around
    index (100, 12, 40))."""
    g = vdb.FloatGrid()
    g.name, g.gridClass, g.transform = "density", FOG, vdb.createLinearTransform(0.1)
    g.fill((0, 0, 0), (127, 63, 63), 0.0, True)
    acc = g.getAccessor()
    for i in range(94, 107):
        for j in range(6, 19):
            for k in range(34, 47):
                d2 = (i - 100) ** 2 + (j - 12) ** 2 + (k - 40) ** 2
                if d2 <= 25:
                    acc.setValueOn((i, j, k), 2.0 * (1.0 - d2 / 25.0) + 0.25)
    return g


def generate(out):
    import os
    w = lambda name, grids, **kw: vdb.write(os.path.join(out, name), grids, **kw)
    w("blender_smoke.vdb", make_blender())
    w("houdini_pyro.vdb", make_houdini(), metadata=HOUDINI_METADATA)
    w("dense_plume.vdb", [make_dense()])


FILES = ["blender_smoke.vdb", "houdini_pyro.vdb", "dense_plume.vdb"]
