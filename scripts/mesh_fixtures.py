"""Unstructured-mesh fixtures (VTK .vtu / .vtk) written by meshio and VTK, and the
reference values computed by VTK itself (vtkXMLUnstructuredGridReader /
vtkUnstructuredGridReader + vtkProbeFilter).

Imported by make_fixtures.py (which re-executes itself under /opt/murk-venv, where
meshio and vtk are installed).  Everything is deterministic: fixed seeds, fixed
coordinates; the reference is recomputed from the files as written.
"""
import itertools
import os
import random

import meshio
import numpy as np
import vtk
from vtk.util.numpy_support import vtk_to_numpy

# --- Meshes


def lattice(xs, ys, zs):
    """Points of the tensor lattice xs × ys × zs, index (i, j, k) -> i + nx*(j + ny*k)."""
    nx, ny = len(xs), len(ys)
    pts = np.array([[x, y, z] for z in zs for y in ys for x in xs], dtype=np.float64)
    idx = lambda i, j, k: i + nx * (j + ny * k)
    return pts, idx


def hex_corners(idx, i, j, k):
    """VTK_HEXAHEDRON order: bottom (z=k) counter-clockwise seen from +z, then top."""
    return [idx(i, j, k), idx(i + 1, j, k), idx(i + 1, j + 1, k), idx(i, j + 1, k),
            idx(i, j, k + 1), idx(i + 1, j, k + 1), idx(i + 1, j + 1, k + 1), idx(i, j + 1, k + 1)]


# Kuhn (Freudenthal) split of a cube into 6 tets along its main diagonal: conforming
# between neighbouring cubes of a lattice.
KUHN = [(0, 1, 2, 6), (0, 2, 3, 6), (0, 3, 7, 6), (0, 7, 4, 6), (0, 4, 5, 6), (0, 5, 1, 6)]


def vtk_tet(pts, t):
    """Orders a tet as VTK wants it: (0,1,2) with its normal toward 3."""
    a, b, c, d = (pts[v] for v in t)
    if np.dot(np.cross(b - a, c - a), d - a) < 0:
        return [t[0], t[2], t[1], t[3]]
    return list(t)


def tet_lattice(xs, ys, zs):
    pts, idx = lattice(xs, ys, zs)
    tets = []
    for k, j, i in itertools.product(range(len(zs) - 1), range(len(ys) - 1), range(len(xs) - 1)):
        c = hex_corners(idx, i, j, k)
        for t in KUHN:
            tets.append([c[v] for v in t])
    return pts, tets


def jitter_interior(pts, amount, seed):
    """Moves every point not on the boundary of the unit box by up to ±amount per axis."""
    rng = random.Random(seed)
    out = pts.copy()
    for n, p in enumerate(pts):
        interior = all(1e-12 < c < 1 - 1e-12 for c in p)
        if interior:
            out[n] = p + np.array([rng.uniform(-amount, amount) for _ in range(3)])
    return out


def point_fields(pts):
    x, y, z = pts[:, 0], pts[:, 1], pts[:, 2]
    return {
        "density": 0.5 + 0.4 * np.sin(3.0 * x + 1.0) * np.cos(2.0 * y) + 0.3 * z * z,
        "linear": 0.2 + 0.5 * x + 0.3 * y + 0.1 * z,
    }


def make_tets():
    """A jittered Kuhn tet mesh of the unit cube (4³ cubes, 384 tets)."""
    g = np.linspace(0.0, 1.0, 5)
    pts, tets = tet_lattice(g, g, g)
    pts = jitter_interior(pts, 0.06, 17)
    tets = [vtk_tet(pts, t) for t in tets]
    n = len(tets)
    return meshio.Mesh(
        pts, [("tetra", np.array(tets, dtype=np.int64))],
        point_data=point_fields(pts),
        cell_data={"one": [np.ones(n)], "cellid": [np.arange(n, dtype=np.float64) * 0.01]},
    )


def make_mixed():
    """Hexahedra, wedges and pyramids filling [0,3]×[0,2]×[0,2] (3×2×2 unit boxes):
    box (0,0,0) is six pyramids around its centre, box (1,0,0) two wedges, box (2,1,1)
    a hexahedron with a non-planar top (a sheared interior point), the rest hexahedra."""
    xs, ys, zs = [0.0, 1.0, 2.0, 3.0], [0.0, 1.0, 2.0], [0.0, 1.0, 2.0]
    pts, idx = lattice(xs, ys, zs)
    pts = pts.tolist()
    # Shear the interior point (2,1,1) a little: its eight boxes become non-affine.
    pts[idx(2, 1, 1)] = [2.0 + 0.13, 1.0 - 0.08, 1.0 + 0.11]
    hexes, wedges, pyramids = [], [], []
    for k, j, i in itertools.product(range(2), range(2), range(3)):
        c = hex_corners(idx, i, j, k)
        if (i, j, k) == (0, 0, 0):
            centre = len(pts)
            pts.append([0.5, 0.5, 0.5])
            faces = [(c[0], c[3], c[2], c[1]), (c[4], c[5], c[6], c[7]), (c[0], c[1], c[5], c[4]),
                     (c[1], c[2], c[6], c[5]), (c[2], c[3], c[7], c[6]), (c[3], c[0], c[4], c[7])]
            # Base counter-clockwise seen from the apex: these faces are listed outward
            # (clockwise seen from the centre), so reverse each.
            for f in faces:
                pyramids.append([f[3], f[2], f[1], f[0], centre])
        elif (i, j, k) == (1, 0, 0):
            # VTK_WEDGE: (0,1,2) with its normal away from (3,4,5).
            for tri in [(0, 1, 2), (0, 2, 3)]:
                b = [c[v] for v in tri]
                t = [c[v + 4] for v in tri]
                wedges.append([b[0], b[2], b[1], t[0], t[2], t[1]])
        else:
            hexes.append(c)
    pts = np.array(pts, dtype=np.float64)
    blocks = [("hexahedron", np.array(hexes)), ("wedge", np.array(wedges)),
              ("pyramid", np.array(pyramids))]
    cell_data = {"one": [np.ones(len(b[1])) for b in blocks],
                 "cellid": [np.arange(len(b[1]), dtype=np.float64) * 0.1 + 1.0 + n
                            for n, b in enumerate(blocks)]}
    return meshio.Mesh(pts, blocks, point_data=point_fields(pts), cell_data=cell_data)


def make_graded():
    """A Kuhn tet mesh of the unit cube whose spacing doubles from cell to cell in x
    and in y (9 and 9 intervals, 2 in z): cell volumes span 2^16 ≈ 65,000×."""
    def graded(n):
        s = np.cumsum([0.0] + [2.0 ** i for i in range(n)])
        return s / s[-1]
    pts, tets = tet_lattice(graded(9), graded(9)[::-1].copy() * -1 + 1, np.linspace(0, 1, 3))
    tets = [vtk_tet(pts, t) for t in tets]
    n = len(tets)
    return meshio.Mesh(pts, [("tetra", np.array(tets))], point_data=point_fields(pts),
                       cell_data={"one": [np.ones(n)]})


def make_plume():
    """A smoke plume on hexahedra over [-1,1]×[-1,1]×[0,3] (8×8×12 cells, their height
    growing upward as a CFD mesh's would, and the columns sheared sideways with height),
    with point data density, temperature and a colour Cd: the render in docs/guide.md."""
    xs = np.linspace(-1.0, 1.0, 9)
    zs = 3.0 * (np.linspace(0.0, 1.0, 13) ** 1.4)
    pts, idx = lattice(xs, xs, zs)
    pts[:, 0] += 0.15 * pts[:, 2] ** 2 / 9.0
    hexes = [hex_corners(idx, i, j, k)
             for k, j, i in itertools.product(range(12), range(8), range(8))]
    x, y, z = pts[:, 0] - 0.15 * pts[:, 2] ** 2 / 9.0, pts[:, 1], pts[:, 2]
    r = np.sqrt(x * x + y * y)
    width = 0.25 + 0.22 * z
    core = np.clip(1.0 - (r / width) ** 2, 0.0, None)
    density = core * (0.6 + 0.4 * np.sin(5.0 * z + 2.0 * x) ** 2) * np.exp(-0.25 * z)
    temperature = 400.0 + 1100.0 * core * np.exp(-1.5 * z)
    cd = np.stack([0.9 - 0.1 * z / 3.0, 0.8 + 0.0 * z, 0.7 + 0.1 * z / 3.0], axis=1)
    return meshio.Mesh(pts, [("hexahedron", np.array(hexes))],
                       point_data={"density": density, "temperature": temperature, "Cd": cd})


def write_appended(src, dst):
    """ParaView's default: appended raw data, zlib-compressed, UInt64 headers."""
    r = vtk.vtkXMLUnstructuredGridReader()
    r.SetFileName(src)
    r.Update()
    w = vtk.vtkXMLUnstructuredGridWriter()
    w.SetInputData(r.GetOutput())
    w.SetFileName(dst)
    w.SetDataModeToAppended()
    w.EncodeAppendedDataOff()
    w.SetCompressorTypeToZLib()
    w.SetHeaderTypeToUInt64()
    w.Write()


# file name -> (mesh maker, writer)
def _vtu(binary, compression):
    return lambda m, p: meshio.write(p, m, file_format="vtu", binary=binary,
                                     compression=compression)


def _vtk(binary):
    return lambda m, p: meshio.write(p, m, file_format="vtk", binary=binary)


MESH_FILES = {
    "tets_ascii.vtu": (make_tets, _vtu(False, None)),
    "tets_binary.vtu": (make_tets, _vtu(True, None)),
    "tets_zlib.vtu": (make_tets, _vtu(True, "zlib")),
    "tets_ascii.vtk": (make_tets, _vtk(False)),
    "tets_binary.vtk": (make_tets, _vtk(True)),
    "mixed_zlib.vtu": (make_mixed, _vtu(True, "zlib")),
    "mixed_ascii.vtk": (make_mixed, _vtk(False)),
    "mixed_binary.vtk": (make_mixed, _vtk(True)),
    "graded.vtu": (make_graded, _vtu(True, "zlib")),
    "plume.vtu": (make_plume, _vtu(True, "zlib")),
}
# Written by VTK from another fixture (appended raw zlib, as ParaView saves).
APPENDED = {"tets_appended.vtu": "tets_zlib.vtu", "mixed_appended.vtu": "mixed_zlib.vtu"}


def generate(out):
    for name, (make, write) in MESH_FILES.items():
        write(make(), os.path.join(out, name))
    for name, src in APPENDED.items():
        write_appended(os.path.join(out, src), os.path.join(out, name))


# --- Reference, from the files as written, by VTK

VTK_NAMES = {10: "tetra", 12: "hexahedron", 13: "wedge", 14: "pyramid"}


def read_vtk(path):
    r = (vtk.vtkXMLUnstructuredGridReader() if path.endswith(".vtu")
         else vtk.vtkUnstructuredGridReader())
    r.SetFileName(path)
    if path.endswith(".vtk"):
        r.ReadAllScalarsOn()
        r.ReadAllVectorsOn()
        r.ReadAllFieldsOn()
    r.Update()
    return r.GetOutput()


def array_info(arrays):
    out = {}
    for n in range(arrays.GetNumberOfArrays()):
        a = arrays.GetArray(n)
        lo, hi = a.GetRange(-1 if a.GetNumberOfComponents() > 1 else 0)
        out[a.GetName()] = {"components": a.GetNumberOfComponents(), "min": lo, "max": hi}
    return out


def probe_points(bounds, count, seed):
    """Deterministic points strictly inside the bounds' box, shrunk by 2%."""
    rng = random.Random(seed)
    lo = [bounds[0], bounds[2], bounds[4]]
    hi = [bounds[1], bounds[3], bounds[5]]
    pts = []
    for _ in range(count):
        pts.append([l + (h - l) * (0.02 + 0.96 * rng.random()) for l, h in zip(lo, hi)])
    return pts


def probe(grid, pts):
    ps = vtk.vtkPoints()
    for p in pts:
        ps.InsertNextPoint(*p)
    poly = vtk.vtkPolyData()
    poly.SetPoints(ps)
    pf = vtk.vtkProbeFilter()
    pf.SetInputData(poly)
    pf.SetSourceData(grid)
    pf.Update()
    out = pf.GetOutput().GetPointData()
    valid = vtk_to_numpy(out.GetArray(pf.GetValidPointMaskArrayName())).tolist()
    values = {}
    for n in range(out.GetNumberOfArrays()):
        a = out.GetArray(n)
        if a.GetName() == pf.GetValidPointMaskArrayName() or a.GetNumberOfComponents() != 1:
            continue
        values[a.GetName()] = [float(v) for v in vtk_to_numpy(a)]
    return valid, values


def in_cell(grid, pts):
    """VTK's interpolation (vtkCell.EvaluatePosition weights) in the cell that really
    contains each point: every weight >= -1e-12.  vtkProbeFilter accepts any cell
    within 1e-3 of its parametric range (vtkTetra::EvaluatePosition) and extrapolates
    in it, which in the graded mesh is off by 2e-4 next to a cell 500× larger."""
    out = {grid.GetPointData().GetArrayName(n): [] for n in range(grid.GetPointData().GetNumberOfArrays())}
    out.update({grid.GetCellData().GetArrayName(n): [] for n in range(grid.GetCellData().GetNumberOfArrays())})
    cell_of = []
    for p in pts:
        found = None
        for c in range(grid.GetNumberOfCells()):
            cell = grid.GetCell(c)
            b = cell.GetBounds()
            if not (b[0] <= p[0] <= b[1] and b[2] <= p[1] <= b[3] and b[4] <= p[2] <= b[5]):
                continue
            closest, pc, d2 = [0.0] * 3, [0.0] * 3, vtk.reference(0.0)
            sub = vtk.reference(0)
            w = [0.0] * cell.GetNumberOfPoints()
            cell.EvaluatePosition(p, closest, sub, pc, d2, w)
            if min(w) >= -1e-12:
                found = (c, cell, w)
                break
        cell_of.append(-1 if found is None else found[0])
        for n in range(grid.GetPointData().GetNumberOfArrays()):
            a = grid.GetPointData().GetArray(n)
            if found is None:
                out[a.GetName()].append(0.0)
            else:
                c, cell, w = found
                out[a.GetName()].append(float(sum(
                    wi * a.GetComponent(cell.GetPointId(k), 0) for k, wi in enumerate(w))))
        for n in range(grid.GetCellData().GetNumberOfArrays()):
            a = grid.GetCellData().GetArray(n)
            out[a.GetName()].append(0.0 if found is None else float(a.GetComponent(found[0], 0)))
    return cell_of, out


def file_reference(path, seed):
    g = read_vtk(path)
    types = {}
    for n in range(g.GetNumberOfCells()):
        t = VTK_NAMES.get(g.GetCellType(n), str(g.GetCellType(n)))
        types[t] = types.get(t, 0) + 1
    bounds = list(g.GetBounds())
    pts = probe_points(bounds, 60, seed)
    valid, values = probe(g, pts)
    return {
        "points": g.GetNumberOfPoints(),
        "cells": types,
        "bounds": bounds,
        "point_data": array_info(g.GetPointData()),
        "cell_data": array_info(g.GetCellData()),
        "probe": {"points": pts, "valid": [int(v) for v in valid], "values": values},
        "in_cell": dict(zip(("cell", "values"), in_cell(g, pts))),
    }


def reference(d):
    names = sorted(list(MESH_FILES) + list(APPENDED))
    return {"vtk_version": vtk.vtkVersion.GetVTKVersion(),
            "meshio_version": meshio.__version__,
            "files": {n: file_reference(os.path.join(d, n), 100 + i)
                      for i, n in enumerate(names)}}
