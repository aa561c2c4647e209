#!/opt/murk-venv/bin/python
"""murk against Mitsuba 3 (a path tracer nobody here wrote): the same density, camera,
sigma and sun, single scattering and all orders, and the time each needs for 1 %
relative RMSE.

    scripts/peer_mitsuba.py [--vdb fixtures/cloud.vdb] [--scales 1,4] [--res 160x90]
        [--murk-spp 64] [--murk-single-spp N] [--mitsuba-spp 64]
        [--variant scalar_rgb|llvm_ad_rgb]
        [--threads 1] [--out DIR]

Needs Mitsuba 3 (`pip install mitsuba` in /opt/murk-venv; llvm_ad_rgb also needs
DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM-19.so) and pyopenvdb for
/usr/bin/python3 (python3-openvdb), which copies the grid into a dense array.

How the scenes are matched:
- OpenVDB values sit on integer index points, Mitsuba's `gridvolume` at cell centres:
  the dense copy is padded with one zero voxel on every side, and the unit cube is
  mapped to index [lo − 1.5, hi + 1.5] (lo, hi: the grid's index bounds), so Mitsuba's
  trilinear lookup is OpenVDB's BoxSampler.
- Medium: `heterogeneous`, sigma_t = density × (σa + σs) × scale, albedo σs/(σa + σs),
  Henyey–Greenstein g (same sign convention). Inside a `cube` with a `null` BSDF.
- Sun: murk's `sun:DX,DY,DZ:1,1,1:E` points toward the sun and E is irradiance;
  Mitsuba's `directional` takes the direction light travels, −(DX,DY,DZ), and the same
  irradiance.
- Camera: perspective, 40° horizontal field of view, box pixel filter, the same eye
  and target (passed to murk with --eye/--look-at).
- `volpath` with max_depth 2 is single scattering; max_depth −1 is all orders.

Noise is measured, not assumed: each renderer renders twice with different seeds; the
relative RMSE between the two, over √2, is one render's noise. A renderer's time to
1 % is its fixed cost (load, murk's shadow-map bake) plus its render time × (noise /
1 %)² (error falls as 1/√spp), from the second of its two renders (Mitsuba's kernels
compiled, caches warm). Both are timed in CPU seconds (user + sys: murk's process;
Mitsuba's own process around its calls, its JIT threads included) and in wall seconds,
at the same thread count (`--threads`, default 1: murk's `--threads`, Dr.Jit's
`set_thread_count`); the table's time to 1 % is in CPU seconds, wall in brackets.
murk's fixed CPU cost is measured by a 1-spp render of the same scene. murk's path
tracer computes A and Z on a pixel's first 16 samples only, so its render time is
a + b·spp rather than proportional to spp: for `path` it also renders 16 spp, and its
time to 1 % is that line's value at the spp where the noise reaches 1 %
(spp × (noise / 1 %)², the noise measured at --murk-spp); Mitsuba's render time is
proportional to spp. The machine's load average is recorded with each row: on a
shared machine both renderers' times move with it. The comparison of murk
with Mitsuba is "within the noise" when their relative RMSE is near √(n_murk² +
n_mitsuba²).
"""

import argparse
import json
import math
import os
import resource
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DUMP = r"""
import sys, numpy as np, pyopenvdb as vdb
g = vdb.read(sys.argv[1], 'density')
(lo, hi) = g.evalActiveVoxelBoundingBox()
n = [hi[i] - lo[i] + 1 for i in range(3)]
a = np.zeros(n, dtype=np.float32)
g.copyToArray(a, ijk=lo)
vs = g.transform.voxelSize()
np.savez(sys.argv[2], a=a, lo=np.array(lo), vs=np.array(vs))
"""


# murk's path tracer computes A and Z on this many of a pixel's samples
# (src/render/mod.rs, PATH_OPACITY_SAMPLES).
PATH_OPACITY_SAMPLES = 16


def dense_grid(vdb_path, tmp):
    out = os.path.join(tmp, "grid.npz")
    subprocess.run(["/usr/bin/python3", "-c", DUMP, vdb_path, out], check=True)
    z = np.load(out)
    return z["a"], z["lo"], z["vs"]


def load_exr(path):
    """The channels of an EXR by name, over its whole display window (murk writes only
    the data window where something is; oiiotool --croptofull pads it with zeros)."""
    import mitsuba as mi

    full = path + ".full.exr"
    subprocess.run(["oiiotool", path, "--croptofull", "-o", full], check=True)
    b = mi.Bitmap(full)
    a = np.array(b, copy=False).astype(np.float64)
    names = [b.struct_()[i].name for i in range(b.channel_count())]
    return {n: a[..., i] for i, n in enumerate(names)}


def murk_render(args, scale, mode, spp, seed, out):
    cmd = [
        os.path.join(ROOT, "target/release/murk"), "render", args.vdb, "-o", out,
        "--res", args.res, "--eye", args.eye, "--look-at", args.look_at, "--fov", "40",
        "--light", args.sun, "--sigma-a", ",".join([str(args.sigma_a)] * 3),
        "--sigma-s", ",".join([str(args.sigma_s)] * 3), "--g", str(args.g), "--density-scale", str(scale),
        "--scattering", mode, "--spp", str(spp), "--seed", str(seed), "--float",
        "--quiet",
    ]
    cmd += ["--threads", str(args.threads)]
    stats = out + ".json"
    t = time.time()
    c0 = children_cpu()
    subprocess.run(cmd + ["--stats", stats], check=True)
    cpu = children_cpu() - c0
    wall = time.time() - t
    with open(stats) as f:
        render = json.load(f)["stages"]["render"]["seconds"]
    c = load_exr(out)
    # Fixed cost (load, build, shadow-map bake, write) and the pixel loop's, wall; and
    # the whole run's CPU seconds.
    return np.stack([c["R"], c["G"], c["B"]], axis=-1), (wall - render, render, cpu)


def children_cpu():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def self_cpu():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def mitsuba_scene(args, grid, lo, vs, scale):
    import mitsuba as mi

    pad = np.pad(grid, 1)  # one zero voxel on every side
    vol = mi.VolumeGrid(np.ascontiguousarray(np.transpose(pad, (2, 1, 0)))[..., None])
    n = np.array(pad.shape, dtype=float)
    lo_w = (np.array(lo, dtype=float) - 1.5) * vs
    size = n * vs
    T = mi.ScalarTransform4f
    to_world = T().translate(lo_w.tolist()) @ T().scale(size.tolist())
    sigma_t = (args.sigma_a + args.sigma_s) * scale
    albedo = args.sigma_s / (args.sigma_a + args.sigma_s)
    toward = np.array([float(v) for v in args.sun.split(":")[1].split(",")])
    toward /= np.linalg.norm(toward)
    irradiance = float(args.sun.split(":")[3])
    eye = [float(v) for v in args.eye.split(",")]
    target = [float(v) for v in args.look_at.split(",")]
    w, h = (int(v) for v in args.res.split("x"))
    medium = {
        "type": "heterogeneous",
        "sigma_t": {"type": "gridvolume", "grid": vol, "to_world": to_world,
                    "filter_type": "trilinear"},
        "scale": sigma_t,
        "albedo": {"type": "constvolume", "value": albedo},
        "phase": {"type": "hg", "g": args.g},
    }
    return {
        "type": "scene",
        "box": {
            "type": "cube",
            "to_world": to_world @ T().translate([0.5, 0.5, 0.5]) @ T().scale(0.5),
            "bsdf": {"type": "null"},
            "interior": medium,
        },
        "sun": {"type": "directional", "direction": (-toward).tolist(),
                "irradiance": {"type": "rgb", "value": [irradiance] * 3}},
        "sensor": {
            "type": "perspective", "fov": 40, "fov_axis": "x",
            "to_world": T().look_at(origin=eye, target=target, up=[0, 1, 0]),
            "film": {"type": "hdrfilm", "width": w, "height": h,
                     "rfilter": {"type": "box"}, "pixel_format": "rgba"},
            "sampler": {"type": "independent"},
        },
    }


def mitsuba_render(scene_dict, max_depth, spp, seed, threads):
    import drjit as dr
    import mitsuba as mi

    # Dr.Jit's pool at `threads` for the load and render only (reading an EXR with
    # mi.Bitmap hangs in Mitsuba 3.9.1 when the pool has one thread).
    pool = dr.thread_count()
    dr.set_thread_count(threads)
    d = dict(scene_dict)
    d["integrator"] = {"type": "volpath", "max_depth": max_depth}
    t, c0 = time.time(), self_cpu()
    scene = mi.load_dict(d)
    loaded, c1 = time.time(), self_cpu()
    img = np.array(mi.render(scene, spp=spp, seed=seed), dtype=np.float64)
    dr.set_thread_count(pool)
    # Fixed cost (scene load) and the render's (with the JIT compile on a first call),
    # wall; the CPU seconds of each.
    return img[..., :3], (loaded - t, time.time() - loaded, c1 - c0, self_cpu() - c1)


def rel_rmse(a, b, ref):
    return float(np.sqrt(np.mean((a - b) ** 2)) / np.mean(ref))


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--vdb", default=os.path.join(ROOT, "fixtures/cloud.vdb"))
    p.add_argument("--scales", default="1,4")
    p.add_argument("--res", default="160x90")
    p.add_argument("--eye", default="0.075,0.25,7")
    p.add_argument("--look-at", dest="look_at", default="0.075,0.25,-0.025")
    p.add_argument("--sun", default="sun:0.6,1,0.5:1,1,1:6")
    p.add_argument("--sigma-a", dest="sigma_a", type=float, default=0.1)
    p.add_argument("--sigma-s", dest="sigma_s", type=float, default=2.0)
    p.add_argument("--g", type=float, default=0.0)
    p.add_argument("--murk-spp", dest="murk_spp", type=int, default=64)
    p.add_argument("--mitsuba-spp", dest="mitsuba_spp", type=int, default=64)
    p.add_argument("--murk-single-spp", dest="murk_single_spp", type=int, default=None,
                   help="murk's spp for single scattering (default: --murk-spp)")
    p.add_argument("--variant", default="scalar_rgb")
    p.add_argument("--threads", type=int, default=1, help="threads of both renderers")
    p.add_argument("--out", default=None, help="write the table and numbers (JSON) here")
    args = p.parse_args()

    import mitsuba as mi

    mi.set_variant(args.variant)
    tmp = tempfile.mkdtemp(prefix="peer-mitsuba-")
    grid, lo, vs = dense_grid(args.vdb, tmp)
    rows = []
    for scale in [float(s) for s in args.scales.split(",")]:
        scene = mitsuba_scene(args, grid, lo, vs, scale)
        for what, mode, depth in [("single", "single", 2), ("all orders", "path", -1)]:
            spp = args.murk_spp if mode == "path" else (args.murk_single_spp or args.murk_spp)
            m = [murk_render(args, scale, mode, spp, s,
                             os.path.join(tmp, f"m{s}.exr")) for s in (1, 2)]
            k = [mitsuba_render(scene, depth, args.mitsuba_spp, s, args.threads) for s in (1, 2)]
            murk_img = 0.5 * (m[0][0] + m[1][0])
            mi_img = 0.5 * (k[0][0] + k[1][0])
            # One render's noise, from two seeds; of the means of two, over √2 more.
            n_murk = rel_rmse(m[0][0], m[1][0], mi_img) / math.sqrt(2)
            n_mi = rel_rmse(k[0][0], k[1][0], mi_img) / math.sqrt(2)
            expected = math.sqrt(n_murk**2 + n_mi**2) / math.sqrt(2)
            # Times of the second render of each (warm caches, compiled kernels).
            (m_fixed, m_px, m_cpu), (k_fixed, k_px, k_fixed_cpu, k_cpu) = m[1][1], k[1][1]
            # murk's fixed CPU cost: a 1-spp render of the same scene.
            m_fixed_cpu = murk_render(args, scale, mode, 1, 3,
                                      os.path.join(tmp, "m1spp.exr"))[1][2]
            # path: its render time is a + b·spp (A and Z on the first 16 samples only);
            # a second point of the line at 16 spp.
            line = None
            if mode == "path" and spp > PATH_OPACITY_SAMPLES:
                lo_fixed, lo_px, lo_cpu = murk_render(
                    args, scale, mode, PATH_OPACITY_SAMPLES, 4,
                    os.path.join(tmp, "m16spp.exr"))[1]
                line = (PATH_OPACITY_SAMPLES, lo_px, max(lo_cpu - m_fixed_cpu, 0.0))
            row = {
                "scale": scale,
                "scattering": what,
                "mean_ratio": float(murk_img.mean() / mi_img.mean()),
                "rel_rmse": rel_rmse(murk_img, mi_img, mi_img),
                "noise_expected": expected,
                "murk_noise": n_murk,
                "mitsuba_noise": n_mi,
                "murk_fixed_seconds": m_fixed,
                "murk_render_seconds": m_px,
                "mitsuba_fixed_seconds": k_fixed,
                "mitsuba_render_seconds": k_px,
                "murk_spp": spp,
                "mitsuba_spp": args.mitsuba_spp,
                "murk_fixed_cpu": m_fixed_cpu,
                "murk_render_cpu": max(m_cpu - m_fixed_cpu, 0.0),
                "mitsuba_fixed_cpu": k_fixed_cpu,
                "mitsuba_render_cpu": k_cpu,
                "threads": args.threads,
                "load_average": os.getloadavg()[0],
            }
            # Error falls as 1/sqrt(spp): the render part scales by (noise / 1 %)².
            for who in ("murk", "mitsuba"):
                f = (row[f"{who}_noise"] / 0.01) ** 2
                row[f"{who}_seconds_to_1pct"] = row[f"{who}_fixed_seconds"] + row[
                    f"{who}_render_seconds"] * f
                row[f"{who}_cpu_to_1pct"] = row[f"{who}_fixed_cpu"] + row[f"{who}_render_cpu"] * f
            if line is not None:
                # murk's path: the line through (16, t16) and (spp, t) at spp × f.
                n_lo, wall_lo, cpu_lo = line
                need = spp * (n_murk / 0.01) ** 2
                at = lambda t_lo, t: t_lo + (t - t_lo) * (need - n_lo) / (spp - n_lo)
                row["murk_16spp_render_seconds"] = wall_lo
                row["murk_16spp_render_cpu"] = cpu_lo
                row["murk_seconds_to_1pct"] = m_fixed + at(wall_lo, m_px)
                row["murk_cpu_to_1pct"] = m_fixed_cpu + at(cpu_lo, row["murk_render_cpu"])
            rows.append(row)
            print(json.dumps(row), flush=True)
    lines = [
        f"Mitsuba {mi.__version__} `{args.variant}`, {args.res}, {os.path.basename(args.vdb)}, "
        f"{args.sun}, σa {args.sigma_a}, σs {args.sigma_s}, g {args.g}; murk {args.murk_spp} spp "
        f"(single scattering {args.murk_single_spp or args.murk_spp}), "
        f"Mitsuba {args.mitsuba_spp} spp, two seeds each; {args.threads} thread(s) each; "
        f"times to 1 % in CPU seconds (wall in brackets); load average "
        f"{min(r['load_average'] for r in rows):.1f}–{max(r['load_average'] for r in rows):.1f}.",
        "",
        "| density | scattering | mean ratio murk/Mitsuba | rel. RMSE murk vs Mitsuba | expected from the noise | murk noise | Mitsuba noise | murk CPU s to 1 % | Mitsuba CPU s to 1 % | murk / Mitsuba CPU time (wall) |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| ×{r['scale']:g} | {r['scattering']} | {r['mean_ratio']:.4f} | {r['rel_rmse']:.2e} | "
            f"{r['noise_expected']:.2e} | {r['murk_noise']:.2e} | {r['mitsuba_noise']:.2e} | "
            f"{r['murk_cpu_to_1pct']:.1f} ({r['murk_seconds_to_1pct']:.1f}) | "
            f"{r['mitsuba_cpu_to_1pct']:.1f} ({r['mitsuba_seconds_to_1pct']:.1f}) | "
            f"{r['murk_cpu_to_1pct'] / r['mitsuba_cpu_to_1pct']:.2f} "
            f"({r['murk_seconds_to_1pct'] / r['mitsuba_seconds_to_1pct']:.2f}) |")
    table = "\n".join(lines)
    print(table)
    if args.out:
        os.makedirs(args.out, exist_ok=True)
        with open(os.path.join(args.out, "peer_mitsuba.md"), "w") as f:
            f.write(table + "\n")
        with open(os.path.join(args.out, "peer_mitsuba.json"), "w") as f:
            json.dump(rows, f, indent=1)


if __name__ == "__main__":
    sys.exit(main())
