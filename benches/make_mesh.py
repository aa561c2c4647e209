"""Makes the mesh benchmark's inputs (scripts/bench_mesh.sh): a jittered Kuhn tet mesh
of the unit cube with N³ cubes (6 N³ tetrahedra; N = 56 gives 1,053,696) and a smooth
point-data density, written by meshio as .vtu (binary, zlib); and the same density
resampled by VTK (vtkProbeFilter: VTK's own interpolation in the mesh) onto a grid of
voxel size 1/(2N), written by pyopenvdb as .vdb.

    /opt/murk-venv/bin/python benches/make_mesh.py N OUT.vtu OUT.vdb
"""
import sys
import time

import meshio
import numpy as np
import pyopenvdb as vdb
import vtk
from vtk.util.numpy_support import numpy_to_vtk, vtk_to_numpy


def density(p):
    x, y, z = p[:, 0] - 0.5, p[:, 1] - 0.5, p[:, 2] - 0.5
    r2 = x * x + y * y + z * z
    blob = np.clip(1.0 - r2 / 0.2, 0.0, None)
    return blob * (1.0 + 0.5 * np.sin(9.0 * x) * np.cos(7.0 * y + 2.0 * z))


def main(n, vtu, vdb_path):
    t0 = time.time()
    g = np.linspace(0.0, 1.0, n + 1)
    z, y, x = np.meshgrid(g, g, g, indexing="ij")
    pts = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    rng = np.random.default_rng(7)
    interior = np.all((pts > 1e-9) & (pts < 1 - 1e-9), axis=1)
    pts[interior] += rng.uniform(-0.2, 0.2, (interior.sum(), 3)) / n
    m = n + 1
    idx = lambda i, j, k: i + m * (j + m * k)
    i, j, k = np.meshgrid(np.arange(n), np.arange(n), np.arange(n), indexing="ij")
    i, j, k = i.ravel(), j.ravel(), k.ravel()
    c = [idx(i, j, k), idx(i + 1, j, k), idx(i + 1, j + 1, k), idx(i, j + 1, k),
         idx(i, j, k + 1), idx(i + 1, j, k + 1), idx(i + 1, j + 1, k + 1), idx(i, j + 1, k + 1)]
    tets = []
    for t in [(0, 1, 2, 6), (0, 2, 3, 6), (0, 3, 7, 6), (0, 7, 4, 6), (0, 4, 5, 6), (0, 5, 1, 6)]:
        tets.append(np.stack([c[v] for v in t], axis=1))
    tets = np.concatenate(tets)
    a, b, cc, d = (pts[tets[:, q]] for q in range(4))
    neg = np.einsum("ij,ij->i", np.cross(b - a, cc - a), d - a) < 0
    tets[neg, 1], tets[neg, 2] = tets[neg, 2].copy(), tets[neg, 1].copy()
    mesh = meshio.Mesh(pts, [("tetra", tets)], point_data={"density": density(pts)})
    meshio.write(vtu, mesh, binary=True, compression="zlib")
    print("mesh: %d points, %d tetrahedra, %.1f s" % (len(pts), len(tets), time.time() - t0))

    t0 = time.time()
    r = vtk.vtkXMLUnstructuredGridReader()
    r.SetFileName(vtu)
    r.Update()
    res = 2 * n
    img = vtk.vtkImageData()
    img.SetDimensions(res + 1, res + 1, res + 1)
    img.SetSpacing(1.0 / res, 1.0 / res, 1.0 / res)
    img.SetOrigin(0, 0, 0)
    probe = vtk.vtkProbeFilter()
    probe.SetInputData(img)
    probe.SetSourceData(r.GetOutput())
    probe.Update()
    vals = vtk_to_numpy(probe.GetOutput().GetPointData().GetArray("density"))
    arr = vals.reshape(res + 1, res + 1, res + 1).transpose(2, 1, 0).astype(np.float32).copy()
    grid = vdb.FloatGrid()
    grid.copyFromArray(arr, ijk=(0, 0, 0), tolerance=0.0)
    grid.name = "density"
    grid.gridClass = vdb.GridClass.FOG_VOLUME
    grid.transform = vdb.createLinearTransform(1.0 / res)
    vdb.write(vdb_path, [grid])
    print("vdb: %d³ voxels resampled by vtkProbeFilter, %d active, %.1f s"
          % (res + 1, grid.activeVoxelCount(), time.time() - t0))


if __name__ == "__main__":
    main(int(sys.argv[1]), sys.argv[2], sys.argv[3])
