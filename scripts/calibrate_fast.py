#!/opt/murk-venv/bin/python
"""Measures `--scattering fast` against full multiple scattering computed by Mitsuba 3
(a path tracer nobody here wrote), on the demo cloud and on variants from thin to dense,
bright to dark, lit from several sides (behind the cloud included).

Usage:  scripts/calibrate_fast.py [--murk target/release/murk] [--out /tmp/calib]
                                  [--spp 1024] [--only NAME,...] [--fast-flags "..."]

Needs Mitsuba 3 in /opt/murk-venv (`pip install mitsuba`; `llvm_ad_rgb` is used when
DRJIT_LIBLLVM_PATH names an LLVM ≥ 16, else `scalar_rgb`) and Debian's python3-openvdb
for /usr/bin/python3 (the dense copy of the grid). Mitsuba references are cached in
--out (keyed by case and spp), so re-running to measure a change of murk is quick.

How murk is matched to Mitsuba (measured): OpenVDB values sit on integer
index points and Mitsuba's gridvolume at cell centres, so the dense copy is padded with
one zero voxel and the unit cube maps to index [lo−0.5, lo+n−0.5]; Mitsuba's
directional light points the way light travels; `volpath` with max_depth 2 is single
scattering (`--check-single` compares that with `--scattering single`).

Prints, per case: murk single's and fast's relative RMSE against Mitsuba's all-orders
image (‖L − L_ref‖₂/‖L_ref‖₂ over R, G, B of the `scatter` layer, as `murk converge`),
the mean ratio, Mitsuba's own noise (two half-spp renders), and murk's CPU seconds.
"""
import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# The camera of every case: the demo cloud seen from the front at 160x90.
CAMERA = dict(eye=(0.5, 1.0, 9.0), look_at=(0.075, 0.25, 0.0), up=(0, 1, 0), fov=36.0)
RES = [160, 90]

# name → (vdb, sigma_a, sigma_s, density_scale, sun direction toward the light, g)
CASES = {
    "demo": ("fixtures/cloud.vdb", 0.1, 2.0, 1.0, (0.6, 1.0, 0.5), 0.0),
    "thin": ("fixtures/cloud.vdb", 0.1, 2.0, 0.25, (0.6, 1.0, 0.5), 0.0),
    "dense": ("fixtures/cloud.vdb", 0.1, 2.0, 4.0, (0.6, 1.0, 0.5), 0.0),
    "white_dense": ("fixtures/cloud.vdb", 0.02, 1.98, 4.0, (0.6, 1.0, 0.5), 0.0),
    "backlit": ("fixtures/cloud.vdb", 0.02, 1.98, 2.0, (-0.3, 0.4, -1.0), 0.0),
    "side": ("fixtures/cloud.vdb", 0.1, 2.0, 2.0, (1.0, 0.1, 0.0), 0.0),
    "below": ("fixtures/cloud.vdb", 0.02, 1.98, 1.0, (0.2, -1.0, 0.3), 0.0),
    "very_dense": ("fixtures/cloud.vdb", 0.02, 1.98, 10.0, (0.6, 1.0, 0.5), 0.0),
    "forward_g": ("fixtures/cloud.vdb", 0.02, 1.98, 2.0, (-0.3, 0.4, -1.0), 0.6),
}
SUN_IRRADIANCE = 6.0

DENSE_SCRIPT = r"""
import sys, json, numpy as np, pyopenvdb as vdb
g = vdb.read(sys.argv[1], 'density')
(lo, hi) = g.evalActiveVoxelBoundingBox()
n = [hi[i] - lo[i] + 1 for i in range(3)]
a = np.zeros(n, dtype=np.float32)
g.copyToArray(a, ijk=lo)
o = g.transform.indexToWorld((0, 0, 0))
x = g.transform.indexToWorld((1, 0, 0))
np.save(sys.argv[2], a)
json.dump({'lo': list(lo), 'origin': list(o), 'voxel': x[0] - o[0]}, open(sys.argv[3], 'w'))
"""


def dense_grid(vdb_path, out):
    npy, meta = os.path.join(out, "dense.npy"), os.path.join(out, "dense.json")
    subprocess.run(["/usr/bin/python3", "-c", DENSE_SCRIPT, vdb_path, npy, meta], check=True)
    return np.load(npy), json.load(open(meta))


def mitsuba_render(case, spp, max_depth, out, seed=0):
    import mitsuba as mi

    vdb, sa, ss, scale, sun, g = case
    a, meta = dense_grid(os.path.join(ROOT, vdb), out)
    pad = np.pad(a, 1)  # one zero voxel on every side
    n = np.array(pad.shape, dtype=float)
    lo = np.array(meta["lo"], dtype=float) - 1.0
    v = meta["voxel"]
    origin = np.array(meta["origin"])
    T = mi.ScalarTransform4f
    # unit cube → index [lo − 0.5, lo + n − 0.5] → world
    to_world = (
        T().translate(mi.ScalarPoint3f(*origin))
        .scale(v)
        .translate(mi.ScalarPoint3f(*(lo - 0.5)))
        .scale(mi.ScalarPoint3f(*n))
    )
    grid = mi.VolumeGrid(np.ascontiguousarray(pad.transpose(2, 1, 0))[..., None])
    st = (sa + ss) * scale
    medium = {
        "type": "heterogeneous",
        "albedo": {"type": "constvolume", "value": ss / (sa + ss)},
        "sigma_t": {"type": "gridvolume", "grid": grid, "to_world": to_world, "filter_type": "trilinear"},
        "scale": st,
        "phase": {"type": "hg", "g": g} if g != 0 else {"type": "isotropic"},
    }
    d = np.array(sun, dtype=float)
    d /= np.linalg.norm(d)
    eye, at, up = CAMERA["eye"], CAMERA["look_at"], CAMERA["up"]
    scene = {
        "type": "scene",
        "integrator": {"type": "volpath", "max_depth": max_depth, "rr_depth": 5},
        "sensor": {
            "type": "perspective",
            "fov": CAMERA["fov"],
            "fov_axis": "x",
            "to_world": T().look_at(origin=eye, target=at, up=up),
            "sampler": {"type": "independent", "sample_count": spp, "seed": seed},
            "film": {"type": "hdrfilm", "width": RES[0], "height": RES[1], "rfilter": {"type": "box"}, "pixel_format": "rgb"},
        },
        "sun": {"type": "directional", "direction": (-d).tolist(), "irradiance": {"type": "rgb", "value": SUN_IRRADIANCE}},
        "box": {
            "type": "cube",
            "to_world": to_world @ T().translate(mi.ScalarPoint3f(0.5, 0.5, 0.5)) @ T().scale(0.5),
            "bsdf": {"type": "null"},
            "interior": medium,
        },
    }
    img = mi.render(mi.load_dict(scene), spp=spp, seed=seed)
    return np.array(img, dtype=np.float64)[..., :3]


def reference(name, spp, max_depth, out):
    """Mitsuba's image (and its noise from two halves), cached."""
    path = os.path.join(out, f"mitsuba_{name}_{RES[0]}x{RES[1]}_{spp}_{max_depth}.npz")
    if os.path.exists(path):
        z = np.load(path)
        return z["img"], float(z["noise"])
    t = time.time()
    h1 = mitsuba_render(CASES[name], spp // 2, max_depth, out, seed=1)
    h2 = mitsuba_render(CASES[name], spp // 2, max_depth, out, seed=2)
    img = 0.5 * (h1 + h2)
    # Each half's error is √2 × the mean's: ‖h1 − h2‖ = 2·‖mean − truth‖ (in expectation).
    noise = float(np.linalg.norm(h1 - h2) / 2 / max(np.linalg.norm(img), 1e-30))
    np.savez(path, img=img, noise=noise)
    print(f"  mitsuba {name} max_depth {max_depth}: {time.time() - t:.1f}s", file=sys.stderr)
    return img, noise


def read_layer(exr, layer):
    import mitsuba as mi

    # murk writes a data window around the cloud: widen it to the whole image first.
    full = exr + ".full.exr"
    subprocess.run(["oiiotool", exr, "--croptofull", "-o", full], check=True)
    bm = mi.Bitmap(full)
    parts = dict(bm.split())
    if layer not in parts:
        raise KeyError(f"{exr}: no layer {layer} (has {list(parts)})")
    return np.array(parts[layer], dtype=np.float64)[..., :3]


def murk_render(murk, name, mode_flags, out):
    vdb, sa, ss, scale, sun, g = CASES[name]
    exr = os.path.join(out, f"murk_{name}.exr")
    c = CAMERA
    args = [
        murk, "render", os.path.join(ROOT, vdb), "-o", exr, "--quiet",
        "--res", f"{RES[0]}x{RES[1]}", "--spp", "16",
        "--eye", ",".join(map(str, c["eye"])), "--look-at", ",".join(map(str, c["look_at"])),
        "--up", ",".join(map(str, c["up"])), "--fov", str(c["fov"]),
        "--sigma-a", f"{sa},{sa},{sa}", "--sigma-s", f"{ss},{ss},{ss}", "--density-scale", str(scale), "--g", str(g),
        "--light", f"sun:{sun[0]},{sun[1]},{sun[2]}:1,1,1:{SUN_IRRADIANCE}",
    ] + [f for f in mode_flags if "=" not in f]
    env = dict(os.environ)
    env.update(f.split("=", 1) for f in mode_flags if "=" in f)  # NAME=VALUE tokens: environment
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(args, check=True, env=env)
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    return read_layer(exr, "scatter"), cpu


def rel_rmse(got, want):
    return float(np.linalg.norm(got - want) / max(np.linalg.norm(want), 1e-30))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--murk", default=os.path.join(ROOT, "target/release/murk"))
    ap.add_argument("--out", default=os.path.join(tempfile.gettempdir(), "murk_calibrate_fast"))
    ap.add_argument("--spp", type=int, default=1024)
    ap.add_argument("--only", default="")
    ap.add_argument("--res", default=f"{RES[0]}x{RES[1]}", help="WxH (160x90)")
    ap.add_argument("--fast-flags", default="--scattering fast")
    ap.add_argument("--single-flags", default="--scattering single")
    ap.add_argument("--check-single", action="store_true")
    ap.add_argument("--json", default="")
    ap.add_argument(
        "--export-demo",
        default="",
        help="write the demo case's Mitsuba image, 2×2-averaged, as little-endian f32 "
        "[row][column][RGB] (tests/fast_scattering.rs reads fixtures/mitsuba_demo_ms.f32)",
    )
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    RES[:] = [int(v) for v in a.res.split("x")]
    import mitsuba as mi

    variant = "llvm_ad_rgb" if os.environ.get("DRJIT_LIBLLVM_PATH") else "scalar_rgb"
    mi.set_variant(variant)
    if a.export_demo:
        ref, noise = reference("demo", a.spp, -1, a.out)
        h, w = ref.shape[0] // 2 * 2, ref.shape[1] // 2 * 2
        r = ref[:h, :w].reshape(h // 2, 2, w // 2, 2, 3).mean(axis=(1, 3))
        r.astype("<f4").tofile(a.export_demo)
        print(f"{a.export_demo}: {r.shape[1]}x{r.shape[0]}, Mitsuba noise {noise:.4f} at full size")
        return
    names = [n for n in CASES if not a.only or n in a.only.split(",")]
    rows = []
    print("| case | single rel. RMSE | fast rel. RMSE | fast mean ratio | Mitsuba noise | single CPU s | fast CPU s |")
    print("|---|---|---|---|---|---|---|")
    for name in names:
        ref, noise = reference(name, a.spp, -1, a.out)
        single, t_single = murk_render(a.murk, name, a.single_flags.split(), a.out)
        fast, t_fast = murk_render(a.murk, name, a.fast_flags.split(), a.out)
        row = dict(
            case=name,
            single=rel_rmse(single, ref),
            fast=rel_rmse(fast, ref),
            ratio=float(fast.sum() / max(ref.sum(), 1e-30)),
            noise=noise,
            single_cpu=t_single,
            fast_cpu=t_fast,
        )
        if a.check_single:
            ref1, noise1 = reference(name, a.spp, 2, a.out)
            row["single_vs_mitsuba_single"] = rel_rmse(single, ref1)
            row["mitsuba_single_noise"] = noise1
        rows.append(row)
        print(
            f"| {name} | {row['single']:.3f} | {row['fast']:.3f} | {row['ratio']:.3f} | {noise:.3f} "
            f"| {t_single:.2f} | {t_fast:.2f} |"
            + (f" single vs Mitsuba single {row['single_vs_mitsuba_single']:.4f} (noise {row['mitsuba_single_noise']:.4f})" if a.check_single else ""),
            flush=True,
        )
    if a.json:
        json.dump(rows, open(a.json, "w"), indent=1)


if __name__ == "__main__":
    main()
