#!/usr/bin/python3
"""Generate murk's OpenVDB test fixtures and the reference.json computed by OpenVDB.

Usage:
    /usr/bin/python3 scripts/make_fixtures.py OUTDIR          # write *.vdb + reference.json
    /usr/bin/python3 scripts/make_fixtures.py --check FIXDIR  # regenerate in a temp dir, compare

Needs Debian's python3-openvdb (pyopenvdb + numpy) and libopenvdb-tools (vdb_tool), and
for the mesh fixtures (mesh_fixtures.py) meshio and vtk, for the water-drop phase
functions (mie_reference.py) miepython, from PyPI: run under /usr/bin/python3 the script
re-executes itself under /opt/murk-venv/bin/python (a venv with system site packages,
set up by .ci/run) when meshio or miepython is not importable.
All data is deterministic (integer-hash noise, fixed seeds); only the UUIDs
inside the .vdb files change between runs.  Every reference number is
computed from the grids as READ BACK from the written files, so half-float
rounding etc. is exactly what is on disk.
"""
import itertools
import json
import math
import os
import random
import shutil
import struct
import subprocess
import sys
import tempfile
import zlib

VENV_PYTHON = "/opt/murk-venv/bin/python"
try:
    import meshio  # noqa: F401  (only to know whether this interpreter has it)
    import miepython  # noqa: F401
except ImportError:
    if os.path.exists(VENV_PYTHON) and os.environ.get("MURK_FIXTURES_REEXEC") != "1":
        os.environ["MURK_FIXTURES_REEXEC"] = "1"
        os.execv(VENV_PYTHON, [VENV_PYTHON] + sys.argv)
    sys.exit("make_fixtures.py: meshio or miepython is not installed here nor in %s "
             "(see .ci/run)" % VENV_PYTHON)

import numpy as np
import pyopenvdb as vdb

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import mesh_fixtures  # noqa: E402
import mie_reference  # noqa: E402
import production_fixtures  # noqa: E402

FOG = vdb.GridClass.FOG_VOLUME

# --- Deterministic noise: integer hash -> value noise -> fBm.  Only +,-,*,/,
# sqrt and integer ops, so the values are identical on any IEEE-754 machine.


def _hash01(ix, iy, iz, seed):
    """Hash integer lattice coordinates (int64 arrays) to floats in [0, 1)."""
    m = np.uint32(0xFFFFFFFF)
    h = (ix.astype(np.int64) & 0xFFFFFFFF).astype(np.uint32) * np.uint32(0x8DA6B343)
    h ^= (iy.astype(np.int64) & 0xFFFFFFFF).astype(np.uint32) * np.uint32(0xD8163841)
    h ^= (iz.astype(np.int64) & 0xFFFFFFFF).astype(np.uint32) * np.uint32(0xCB1AB31F)
    h ^= np.uint32(seed * 0x9E3779B9 & 0xFFFFFFFF)
    for _ in range(2):  # murmur3-style finaliser
        h ^= h >> np.uint32(16)
        h = (h * np.uint32(0x7FEB352D)) & m
        h ^= h >> np.uint32(15)
        h = (h * np.uint32(0x846CA68B)) & m
    return (h >> np.uint32(8)).astype(np.float64) / float(1 << 24)


def value_noise(x, y, z, seed):
    """Smooth (quintic-faded) trilinear value noise in [0, 1)."""
    fx, fy, fz = np.floor(x), np.floor(y), np.floor(z)
    ix, iy, iz = fx.astype(np.int64), fy.astype(np.int64), fz.astype(np.int64)
    fade = lambda t: t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
    u, v, w = fade(x - fx), fade(y - fy), fade(z - fz)
    c = {(a, b, d): _hash01(ix + a, iy + b, iz + d, seed)
         for a, b, d in itertools.product((0, 1), repeat=3)}
    lerp = lambda a, b, t: a + (b - a) * t
    x00, x10 = lerp(c[0, 0, 0], c[1, 0, 0], u), lerp(c[0, 1, 0], c[1, 1, 0], u)
    x01, x11 = lerp(c[0, 0, 1], c[1, 0, 1], u), lerp(c[0, 1, 1], c[1, 1, 1], u)
    return lerp(lerp(x00, x10, v), lerp(x01, x11, v), w)


def fbm(x, y, z, octaves, seed):
    """Fractal sum of value noise, normalised to roughly [0, 1]."""
    total, amp, norm = 0.0, 1.0, 0.0
    for o in range(octaves):
        total = total + amp * value_noise(x, y, z, seed + 101 * o)
        norm += amp
        x, y, z, amp = x * 2.0 + 17.31, y * 2.0 - 9.17, z * 2.0 + 5.53, amp * 0.5
    return total / norm


# --- Grid builders


def index_coords(lo, hi):
    """float64 index-coordinate arrays (i, j, k) for the inclusive box lo..hi."""
    axes = [np.arange(a, b + 1, dtype=np.float64) for a, b in zip(lo, hi)]
    return np.meshgrid(*axes, indexing="ij")


def grid_from_array(name, arr, lo, transform, cls=FOG, half=False):
    """FloatGrid/Vec3SGrid from a dense array whose [0,0,0] sits at index lo.
    Voxels equal to the background (0) stay inactive."""
    g = vdb.Vec3SGrid() if arr.ndim == 4 else vdb.FloatGrid()
    tolerance = (0.0, 0.0, 0.0) if arr.ndim == 4 else 0.0
    g.copyFromArray(np.ascontiguousarray(arr, dtype=np.float32), tuple(lo), tolerance)
    g.name, g.transform, g.saveFloatAsHalf = name, transform, half
    if cls is not None:
        g.gridClass = cls
    return g


def blob(name, lo, hi, transform, cls=FOG):
    """A lopsided polynomial blob (value grows along +i, +j) filling lo..hi:
    asymmetric on purpose so axis or transform mix-ups change the samples."""
    i, j, k = index_coords(lo, hi)
    c = [(a + b) / 2.0 for a, b in zip(lo, hi)]
    r = [(b - a) / 2.0 for a, b in zip(lo, hi)]
    u, v, w = (i - c[0]) / r[0], (j - c[1]) / r[1], (k - c[2]) / r[2]
    shape = np.maximum(1.0 - (u * u + v * v + w * w), 0.0)
    return grid_from_array(name, shape * (1.0 + 0.5 * u + 0.25 * v), lo, transform, cls)


def make_cloud():
    """Cumulus-like cloud: a union of spherical puffs (as 1 - distance/radius)
    roughened by fBm, a soft flat base, a window that reaches 0 inside the
    dense box, and a soft saturation so the density peaks a little above 2."""
    lo, hi, vs = (-45, -45, -45), (44, 44, 44), 0.05
    i, j, k = index_coords(lo, hi)
    x, y, z = i * vs, j * vs, k * vs
    s = 1.15
    puffs = [(0.0, -0.2, 0.0, 1.1), (-0.9, -0.45, 0.3, 0.8), (0.95, -0.4, -0.2, 0.85),
             (0.3, 0.55, 0.2, 0.75), (-0.4, 0.35, -0.5, 0.7), (0.2, -0.4, 0.9, 0.7),
             (-0.3, -0.5, -0.9, 0.65), (1.5, -0.6, 0.4, 0.5)]
    field = np.full(x.shape, -1.0)
    for cx, cy, cz, r in puffs:
        d = np.sqrt((x - s * cx) ** 2 + (y - s * cy) ** 2 + (z - s * cz) ** 2)
        field = np.maximum(field, 1.0 - d / (s * r))
    field = field + 0.9 * (fbm(x * 1.6, y * 1.6, z * 1.6, 5, seed=7) - 0.5)
    base = np.clip((y + 1.1) / 0.35, 0.0, 1.0)
    window = np.maximum(1.0 - (x * x + y * y + z * z) / (2.2 * 2.2), 0.0)
    t = np.maximum(4.0 * field * base * window, 0.0)
    return grid_from_array("density", 3.0 * t / (1.5 + t), lo, vdb.createLinearTransform(vs))


def make_pyro():
    lo, hi, vs = (-20, 0, -20), (19, 39, 19), 0.1
    i, j, k = index_coords(lo, hi)
    x, y, z = i * vs, j * vs, k * vs                        # y is up, 0..3.9
    h = y / 3.9
    n = fbm(x * 2.0, y * 2.0 - 1.0, z * 2.0, 3, seed=11)
    radius = (1.2 - 0.5 * h) * (0.7 + 0.6 * n)
    q = np.maximum(1.0 - (x * x + z * z) / (radius * radius), 0.0)
    dens = np.maximum(q * (1.0 - h * h) * (0.4 + 1.2 * n) - 0.05, 0.0)
    mask = dens > 0.0
    heat = q * (1.0 - h) ** 2 * (0.6 + 0.8 * n)
    temp = np.where(mask, 300.0 + 1700.0 * np.minimum(heat, 1.0), 0.0)
    flame = np.where(mask, np.clip(2.5 * heat - 1.0, 0.0, 1.0), 0.0)
    vel = np.stack([-0.8 * z, 1.5 + 2.0 * heat, 0.8 * x], axis=-1) * mask[..., None]
    cd = np.stack([0.95 + 0.0 * h, 0.45 + 0.45 * h, 0.15 + 0.7 * h], axis=-1) * mask[..., None]
    xf = vdb.createLinearTransform(vs)
    return [grid_from_array("density", dens, lo, xf, half=True),
            grid_from_array("temperature", temp, lo, xf, half=True),
            grid_from_array("flame", flame, lo, xf, half=True),
            grid_from_array("vel", vel, lo, xf, cls=None, half=True),
            grid_from_array("Cd", cd, lo, xf, cls=None, half=True)]


def rotated_transform():
    """0.05 voxels, rotated 30 deg about z then 45 deg about x, translated.
    pyopenvdb takes row-vector matrices: world = [i j k 1] * M."""
    def rot(axis, deg):
        c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
        a, b = [(1, 2), (2, 0), (0, 1)][axis]
        m = np.identity(4)
        m[a, a], m[a, b], m[b, a], m[b, b] = c, s, -s, c
        return m
    m = np.diag([0.05, 0.05, 0.05, 1.0]) @ rot(2, 30.0) @ rot(0, 45.0)
    m[3, :3] = (1.5, -0.75, 2.0)
    return vdb.createLinearTransform(m.tolist())


def make_tiles():
    """Values 0.25.. on leaf voxels, 2 on a level-1 tile (8^3), 3 on a level-2
    tile (128^3), 4 on a root tile (4096^3).  Aligned fills stay tiles."""
    g = vdb.FloatGrid()
    g.name, g.gridClass, g.transform = "density", FOG, vdb.createLinearTransform(0.05)
    acc = g.getAccessor()
    for n in range(5):                          # a few leaf voxels in leaf [0,7]^3
        acc.setValueOn((n, n % 3, 1 + n % 2), 0.25 * (n + 1))
    g.fill((8, 0, 0), (15, 7, 7), 2.0)                 # lower internal node tile
    g.fill((128, 0, 0), (255, 127, 127), 3.0)          # upper internal node tile
    g.fill((4096, 0, 0), (8191, 4095, 4095), 4.0)      # root tile
    return g


def make_homogeneous(name, inside):
    lo, hi = (-40, -40, -20), (39, 39, 39)
    i, j, k = index_coords(lo, hi)
    arr = np.where(inside(i, j, k), 1.0, 0.0)
    return grid_from_array(name, arr, lo, vdb.createLinearTransform(0.05))


def write_bad_types(path, tmp):
    """int32 + bool + points grids.  pyopenvdb has no Int32Grid, so an
    int32 grid is made by writing a FloatGrid whose float bit patterns are the
    wanted int32 values and renaming its tree type Tree_float_5_4_3 ->
    Tree_int32_5_4_3 (same length, same 4-byte value layout).  The points grid
    comes from vdb_tool -points2vdb."""
    ints = vdb.FloatGrid()
    ints.name, acc = "ival", ints.getAccessor()
    for n in range(27):  # 3x3x3 voxels, values -40, -33, ..., 142
        acc.setValueOn((n % 3, n // 3 % 3, n // 9), int_as_float(7 * n - 40))
    mask = vdb.BoolGrid()
    mask.name = "mask"  # 10x10x5 voxels + 1 stray one
    mask.fill((0, 0, 0), (9, 9, 4), True)
    mask.getAccessor().setValueOn((12, 0, 0), True)
    raw = os.path.join(tmp, "int_bool.vdb")
    vdb.write(raw, [ints, mask])
    with open(raw, "rb") as f:
        data = f.read()
    assert data.count(b"Tree_float_5_4_3") == 1
    with open(raw, "wb") as f:
        f.write(data.replace(b"Tree_float_5_4_3", b"Tree_int32_5_4_3"))
    obj = os.path.join(tmp, "points.obj")
    with open(obj, "w") as f:
        for n in range(20):
            f.write("v %g %g %g\n" % (0.1 * n, 0.05 * (n % 4), -0.07 * (n % 5)))
    vdb_tool("-read", raw, "-read", obj, "-points2vdb", "ppv=4", "name=points",
             "-write", "codec=blosc", path)


int_as_float = lambda i: struct.unpack("<f", struct.pack("<i", i))[0]
float_as_int = lambda x: struct.unpack("<i", struct.pack("<f", x))[0]


def write_sequence(out):
    """A tiny Blender-style cache, seq/fluid_0001.vdb .. fluid_0004.vdb: a blob that
    stays put for frames 1 and 2 (the same grid, so a sequence reuses its shadow map)
    and then rises one voxel and grows a voxel per frame."""
    os.makedirs(out, exist_ok=True)
    xf = vdb.createLinearTransform(0.1)
    for frame in range(1, 5):
        move = max(frame - 2, 0)
        lo, hi = (-6, -5 + move, -6), (5, 4 + 2 * move, 5)
        vdb.write(os.path.join(out, "fluid_%04d.vdb" % frame), [blob("density", lo, hi, xf)])


def vdb_tool(*args):
    subprocess.run(["vdb_tool", "-quiet", *args], check=True, stdout=subprocess.DEVNULL)


def generate(out):
    os.makedirs(out, exist_ok=True)
    tmp = tempfile.mkdtemp(prefix="murk_fx_")
    try:
        w = lambda name, grids: vdb.write(os.path.join(out, name), grids)
        w("cloud.vdb", [make_cloud()])
        vdb_tool("-sphere", "voxel=0.05", "radius=1.0", "center=(0,0,0)", "width=3",
                 "name=sphere_ls", "-ls2fog", "name=density", "-write", "codec=blosc",
                 os.path.join(out, "levelset_fog.vdb"))
        w("pyro.vdb", make_pyro())
        # OpenVDB silently drops ZIP for fog volumes and level sets
        # (Archive::setGridCompression), so this grid's class stays "unknown".
        raw = os.path.join(tmp, "zip_src.vdb")
        vdb.write(raw, [blob("density", (-12, -10, -8), (11, 9, 7),
                             vdb.createLinearTransform(0.05), cls=None)])
        vdb_tool("-read", raw, "-write", "codec=zip", os.path.join(out, "zip.vdb"))
        w("rotated.vdb", [blob("density", (-10, -6, -4), (9, 5, 3), rotated_transform())])
        nonuni = vdb.createLinearTransform([[0.05, 0, 0, 0], [0, 0.1, 0, 0],
                                            [0, 0, 0.2, 0], [0, 0, 0, 1]])
        w("nonuniform.vdb", [blob("density", (-16, -8, -4), (15, 7, 3), nonuni)])
        w("tiles.vdb", [make_tiles()])
        w("far.vdb", [blob("density", (999994, -1000006, 999994),
                           (1000005, -999995, 1000005), vdb.createLinearTransform(0.1))])
        empty = vdb.FloatGrid()
        empty.name, empty.gridClass = "density", FOG
        empty.transform = vdb.createLinearTransform(0.05)
        w("empty.vdb", [empty])
        w("sphere.vdb", [make_homogeneous("density", lambda i, j, k: i * i + j * j + k * k <= 400)])
        w("slab.vdb", [make_homogeneous("density", lambda i, j, k: (k >= 0) & (k <= 19))])
        write_bad_types(os.path.join(out, "bad_types.vdb"), tmp)
        write_sequence(os.path.join(out, "seq"))
        mesh_fixtures.generate(out)
        production_fixtures.generate(out)
    finally:
        shutil.rmtree(tmp)
    ref = compute_reference(out)
    with open(os.path.join(out, "reference.json"), "w") as f:
        f.write(dump_json(ref))
    return ref


# --- Reference data, computed from the files as written

FILES = ["cloud.vdb", "levelset_fog.vdb", "pyro.vdb", "zip.vdb", "rotated.vdb",
         "nonuniform.vdb", "tiles.vdb", "far.vdb", "empty.vdb", "sphere.vdb",
         "slab.vdb", "bad_types.vdb"] + production_fixtures.FILES


def file_version(path):
    """VDB header: int64 magic 0x56444220, then uint32 file format version."""
    with open(path, "rb") as f:
        magic, version = struct.unpack("<qI", f.read(12))
    assert magic == 0x56444220, path
    return version


def to_json_value(v, kind):
    if kind == "vec3s":
        return [float(c) for c in v]
    if kind == "int32":
        return float_as_int(v)
    if kind == "bool":
        return bool(v)
    return float(v)


def box_sample(acc, xf, xyz):
    """openvdb::tools::BoxSampler, re-implemented (pyopenvdb has no sampler) in
    float64: index = worldToIndex(xyz) (not cell-centred), i0 = floor(index),
    t = index - i0, trilinear blend of acc.getValue at i0 + {0,1}^3 in the same
    nesting order as BoxSampler::trilinearInterpolation (z, then y, then x).
    OpenVDB itself blends in float32, so expect ~1e-7 relative differences."""
    idx = xf.worldToIndex(tuple(xyz))
    i0 = [math.floor(c) for c in idx]
    t = [c - f for c, f in zip(idx, i0)]
    vals = {}
    for a, b, c in itertools.product((0, 1), repeat=3):
        v = acc.getValue((i0[0] + a, i0[1] + b, i0[2] + c))
        vals[a, b, c] = [float(x) for x in v] if isinstance(v, tuple) else [float(v)]
    lerp = lambda p, q, w: [x + (y - x) * w for x, y in zip(p, q)]
    yz = [lerp(lerp(vals[a, 0, 0], vals[a, 0, 1], t[2]),
               lerp(vals[a, 1, 0], vals[a, 1, 1], t[2]), t[1]) for a in (0, 1)]
    out = lerp(yz[0], yz[1], t[0])
    return out if len(out) == 3 else out[0]


def sample_points(rng, items, bbox):
    """Index-space points: 40 inside active voxels/tiles, 8 on the active
    bbox boundary, 6 well outside it."""
    if not items:  # empty grid: anything is "outside"
        return [[rng.random() * 40 - 20 for _ in range(3)] for _ in range(54)]
    pts = []
    for _ in range(40):
        lo, hi = items[int(rng.random() * len(items))][:2]
        pts.append([a + rng.random() * (b + 1 - a) for a, b in zip(lo, hi)])
    lo, hi = bbox
    mid = [(a + b) / 2.0 for a, b in zip(lo, hi)]
    pts += [list(map(float, lo)), list(map(float, hi))]
    for axis, (end, sign) in itertools.product(range(3), ((lo, -1), (hi, 1))):
        edge, out = list(mid), list(mid)
        edge[axis] = end[axis] + 0.5 * sign                 # half a voxel past the last one
        out[axis] = end[axis] + sign * (5 + 10 * rng.random())  # well outside
        pts += [edge, out]
    return pts


def grid_reference(g, kind, seed):
    xf, acc, md = g.transform, g.getConstAccessor(), g.metadata
    leaf_depth = g.treeDepth - 1
    items, values, by_level = [], [], {"1": 0, "2": 0, "3": 0}
    for it in g.iterOnValues():
        items.append((it.min, it.max))
        values.append((to_json_value(it.value, kind), it.count))
        if it.depth < leaf_depth:
            by_level[str(leaf_depth - it.depth)] += 1
    count = g.activeVoxelCount()
    assert count == sum(n for _, n in values)

    w = lambda ijk: list(xf.indexToWorld(tuple(ijk)))
    o = w((0, 0, 0))
    axes = [[a - b for a, b in zip(w(e), o)] for e in ((1, 0, 0), (0, 1, 0), (0, 0, 1))]
    matrix = [[axes[0][r], axes[1][r], axes[2][r], o[r]] for r in range(3)] + [[0.0, 0.0, 0.0, 1.0]]

    ref = {
        "value_type": kind,
        "class": g.gridClass,
        "half": bool(md.get("is_saved_as_half_float", False)),
        "compression": codec_name(md.get("file_compression", "none")),
        "background": to_json_value(g.background, kind),
        "active_voxel_count": count,
        "leaf_count": g.leafCount(),
        "active_tile_count": sum(by_level.values()),
        "active_tiles_by_level": by_level,
        "voxel_size": list(xf.voxelSize()),
        "index_to_world_matrix": matrix,
        "index_bbox": None, "world_bbox": None, "min": None, "max": None,
    }
    rng = random.Random(seed)
    ijks = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 1), (-1, -1, -1),
            (-3, 5, 11), (7, -2, -9)]
    bbox = None
    if count:
        bbox = [list(c) for c in g.evalActiveVoxelBoundingBox()]
        corners = [[bbox[a][0], bbox[b][1], bbox[c][2]]
                   for a, b, c in itertools.product((0, 1), repeat=3)]
        world = [w(c) for c in corners]
        ref["index_bbox"] = bbox
        ref["world_bbox"] = [[min(p[a] for p in world) for a in range(3)],
                             [max(p[a] for p in world) for a in range(3)]]
        ijks += corners + [items[int(rng.random() * len(items))][0] for _ in range(4)]
        if kind == "vec3s":
            ref["min"] = [min(v[0][c] for v in values) for c in range(3)]
            ref["max"] = [max(v[0][c] for v in values) for c in range(3)]
        else:
            ref["min"] = min(v for v, _ in values)
            ref["max"] = max(v for v, _ in values)
    if kind == "vec3s":
        ref["sum"] = [math.fsum(v[c] * n for v, n in values) for c in range(3)]
    else:
        ref["sum"] = math.fsum(float(v) * n for v, n in values)
    ref["index_to_world"] = [{"ijk": list(c), "xyz": w(c)} for c in ijks]
    ref["samples"] = []
    if kind in ("float", "vec3s"):  # the renderer's value types only
        for p in sample_points(rng, items, bbox):
            xyz = w(p)
            ref["samples"].append({"xyz": xyz, "value": box_sample(acc, xf, xyz)})
    return ref


def codec_name(file_compression):
    for codec in ("blosc", "zip"):
        if codec in file_compression:
            return codec
    return "none"


def vdb_print_grids(path):
    """Parse `vdb_print -l -m` into {grid name: {field: text}} (used for grid
    types pyopenvdb cannot load)."""
    text = subprocess.run(["vdb_print", "-l", "-m", path], check=True,
                          capture_output=True, text=True).stdout
    grids, cur = {}, None
    for line in text.splitlines():
        key, _, val = line.strip().partition(":")
        if line.startswith("Name:"):
            cur = grids.setdefault(val.strip(), {})
        elif cur is not None and val:
            cur.setdefault(key.strip(), val.strip())
        elif cur is not None and line.strip().startswith("Root("):
            cur["Configuration"] = line.strip()
    return grids


def opaque_grid_reference(info):
    """What vdb_print reports for a grid pyopenvdb cannot read (points)."""
    ints = lambda s: [int(x) for x in s.replace("[", "").replace("]", "").split(",")]
    lo, _, hi = info["Bounding box of active voxels"].partition("->")
    tree_type = info["Type"]  # e.g. Tree_ptdataidx32_5_4_3
    return {
        "value_type": tree_type[len("Tree_"):].rsplit("_", 3)[0],
        "class": info.get("class", "unknown"),
        "half": info.get("is_saved_as_half_float", "false") == "true",
        "compression": codec_name(info.get("file_compression", "none")),
        "background": None,
        "active_voxel_count": int(info["Number of active voxels"].replace(",", "")),
        "leaf_count": int(info["Configuration"].split("Leaf(")[1].split(" x")[0]),
        "active_tile_count": int(info["Number of active tiles"].replace(",", "")),
        "active_tiles_by_level": None,
        "index_bbox": [ints(lo), ints(hi)],
        "world_bbox": None, "voxel_size": None, "index_to_world_matrix": None,
        "min": None, "max": None, "sum": None, "index_to_world": [], "samples": [],
    }


def file_grids_reference(path, tmp):
    fname = os.path.basename(path)
    seed = lambda gname: zlib.crc32((fname + "/" + gname).encode())
    try:
        grids, _ = vdb.readAll(path)
    except TypeError:  # a grid type pyopenvdb does not know: go grid by grid
        grids = None
    if grids is not None:
        return {g.name: grid_reference(g, g.valueTypeName, seed(g.name)) for g in grids}
    out = {}
    for name, info in vdb_print_grids(path).items():
        kind = info["Type"][len("Tree_"):].rsplit("_", 3)[0]
        if kind in ("float", "vec3s", "bool"):
            out[name] = grid_reference(vdb.read(path, name), kind, seed(name))
        elif kind == "int32":  # undo the type-name trick, reinterpret the bits
            with open(path, "rb") as f:
                data = f.read().replace(b"Tree_int32_5_4_3", b"Tree_float_5_4_3")
            alias = os.path.join(tmp, "as_float.vdb")
            with open(alias, "wb") as f:
                f.write(data)
            out[name] = grid_reference(vdb.read(alias, name), "int32", seed(name))
        else:
            out[name] = opaque_grid_reference(info)
    return out


def compute_reference(d):
    tmp = tempfile.mkdtemp(prefix="murk_ref_")
    try:
        files = {name: {"file_version": file_version(os.path.join(d, name)),
                        "grids": file_grids_reference(os.path.join(d, name), tmp)}
                 for name in FILES}
    finally:
        shutil.rmtree(tmp)
    return {"openvdb_version": ".".join(map(str, vdb.LIBRARY_VERSION)), "files": files,
            "meshes": mesh_fixtures.reference(d), "water_drop_mie": water_drop_mie()}


_MIE = []


def water_drop_mie():
    """miepython's water-drop phase functions (computed once per run: ~10 s)."""
    if not _MIE:
        _MIE.append(mie_reference.reference())
    return _MIE[0]


def dump_json(ref):
    return json.dumps(ref, sort_keys=True, indent=1, allow_nan=False) + "\n"


# --- --check


def compare(a, b, path, diffs):
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
            if k not in a or k not in b:
                diffs.append("%s/%s: only in %s" % (path, k, "committed" if k in a else "new"))
            else:
                compare(a[k], b[k], path + "/" + k, diffs)
    elif isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for n, (x, y) in enumerate(zip(a, b)):
            compare(x, y, "%s[%d]" % (path, n), diffs)
    elif (isinstance(a, (int, float)) and isinstance(b, (int, float))
          and not isinstance(a, bool) and not isinstance(b, bool)):
        if not math.isclose(a, b, rel_tol=1e-9, abs_tol=1e-12):
            diffs.append("%s: committed %r, new %r" % (path, a, b))
    elif a != b or type(a) is not type(b):
        diffs.append("%s: committed %s, new %s" % (path, json.dumps(a)[:80], json.dumps(b)[:80]))


def check(fixdir):
    with open(os.path.join(fixdir, "reference.json")) as f:
        committed = json.load(f)
    tmp = tempfile.mkdtemp(prefix="murk_check_")
    try:
        fresh = json.loads(dump_json(generate(tmp)))
    finally:
        shutil.rmtree(tmp)
    # Also recompute from the committed .vdb files, so a stale .vdb is caught.
    from_files = json.loads(dump_json(compute_reference(fixdir)))
    ok = True
    for label, new in (("regenerated fixtures", fresh), ("committed .vdb files", from_files)):
        diffs = []
        compare(committed, new, "", diffs)
        if diffs:
            ok = False
            print("reference.json differs from %s (%d differences):" % (label, len(diffs)))
            for line in diffs[:40]:
                print("  " + line)
            if len(diffs) > 40:
                print("  ... and %d more" % (len(diffs) - 40))
    if ok:
        print("OK: %s/reference.json matches regenerated fixtures and the committed files" % fixdir)
    return 0 if ok else 1


def main(argv):
    if len(argv) == 3 and argv[1] == "--check":
        return check(argv[2])
    if len(argv) == 2 and not argv[1].startswith("-"):
        generate(argv[1])
        return 0
    print(__doc__.strip(), file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv))
