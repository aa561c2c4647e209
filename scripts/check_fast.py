#!/opt/murk-venv/bin/python
"""Measures `--scattering fast` against murk's own path tracer on a set of clouds, thin to
dense, albedo 0.8 to 0.995, suns in front, at the side, below and behind.

Usage:  scripts/check_fast.py [--murk target/release/murk] [--out /tmp/murk_check_fast]
                              [--spp 256] [--res 80x45] [--only NAME,...]
                              [--fast-flags "--scattering fast"] [--json FILE]

Per case the reference is two path-traced halves (`--scattering path --spp N --seed 1`
and `--seed 2`, cached in --out keyed by case, size and spp, so re-running after a change
of fast costs only the fast renders). Their difference gives the path tracer's noise:
‖h1 − h2‖ = 2·‖mean − truth‖ in expectation, so `noise = ‖h1 − h2‖/2/‖mean‖`, and fast's
own error is about `√(err² − noise²)` ("fast net" below). Error is the relative RMSE
`‖L − L_ref‖₂/‖L_ref‖₂` over R, G, B of the `scatter` layer, as `murk converge`.

EXR layers are read with `oiiotool` (OpenImageIO's command line tool, which `.ci/run`
installs): the layer is widened to the full display window and written as an
uncompressed float EXR, which this script parses. Needs numpy (the venv's).
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

# The demo cloud's camera in scripts/calibrate_fast.py; other fixtures use murk's framing.
CLOUD_CAM = ["--eye", "0.5,1.0,9.0", "--look-at", "0.075,0.25,0.0", "--up", "0,1,0", "--fov", "36"]

FRONT, SIDE, BELOW, BEHIND = (0.6, 1.0, 0.5), (1.0, 0.1, 0.0), (0.2, -1.0, 0.3), (-0.3, 0.4, -1.0)

# name → (fixture, sigma_a, sigma_s, density scale, sun direction toward the light, extra args)
CASES = {
    # the demo cloud (σt 2.1 at density ~2, ~84 voxels of 0.05 across)
    "demo": ("cloud.vdb", 0.1, 2.0, 1.0, FRONT, CLOUD_CAM),
    "thin": ("cloud.vdb", 0.1, 2.0, 0.25, FRONT, CLOUD_CAM),
    "dense_a80_side": ("cloud.vdb", 0.8, 3.2, 2.0, SIDE, CLOUD_CAM),
    "dense_a95": ("cloud.vdb", 0.1, 2.0, 4.0, FRONT, CLOUD_CAM),
    "white_x4": ("cloud.vdb", 0.02, 1.98, 4.0, FRONT, CLOUD_CAM),
    "white_backlit_x2": ("cloud.vdb", 0.02, 1.98, 2.0, BEHIND, CLOUD_CAM),
    "white_backlit_x4": ("cloud.vdb", 0.02, 1.98, 4.0, BEHIND, CLOUD_CAM),
    "white_below_x4": ("cloud.vdb", 0.02, 1.98, 4.0, BELOW, CLOUD_CAM),
    "white_x10_side": ("cloud.vdb", 0.02, 1.98, 10.0, SIDE, CLOUD_CAM),
    # the fixtures docs/how-it-works.md names
    "fog_front": ("levelset_fog.vdb", 0.1, 20.0, 1.0, FRONT, []),
    "fog_backlit": ("levelset_fog.vdb", 0.1, 20.0, 1.0, BEHIND, []),
    "fog_a95_below": ("levelset_fog.vdb", 0.5, 9.5, 1.0, BELOW, []),
    "plume_below": ("dense_plume.vdb", 0.3, 30.0, 1.0, (0.0, -1.0, 0.0), []),
    "sphere_white_backlit": ("sphere.vdb", 0.03, 5.97, 1.0, BEHIND, []),
    # Held out: fBm clouds no calibration or design step looked at before it was fixed
    # (benches/make_cloud.py, other seeds and sizes; made in --out when first needed).
    # Peak density 2.2 over 9.6 units, so σt 0.5 is thin (τ across ~3), 8 dense (~50).
    "fbm64_thin_front": ("gen:64:11", 0.05, 0.45, 1.0, FRONT, []),
    "fbm64_a99_behind": ("gen:64:11", 0.02, 1.98, 1.0, BEHIND, []),
    "fbm96_dense_side": ("gen:96:23", 0.08, 7.92, 1.0, SIDE, []),
    "fbm96_dense_behind": ("gen:96:23", 0.08, 7.92, 1.0, (0.1, 0.2, -1.0), []),
    "fbm96_a90_below": ("gen:96:23", 0.4, 3.6, 1.0, BELOW, []),
    "fbm64_x4_a99_above": ("gen:64:11", 0.02, 1.98, 4.0, (0.0, 1.0, 0.0), []),
    # Held out too, added after the changes above: forward-scattering phase functions
    # (fast transports orders past the first with the similarity-reduced σs) and a
    # chromatic medium (σ per channel; the lattice then solves each channel).
    "fbm96_g06_behind": ("gen:96:23", 0.04, 3.96, 1.0, (0.1, 0.2, -1.0), ["--g", "0.6"]),
    "demo_g08_x4_front": ("cloud.vdb", 0.02, 1.98, 4.0, FRONT, CLOUD_CAM + ["--g", "0.8"]),
    "fbm64_chromatic_side": ("gen:64:11", "0.05,0.1,0.2", "2.5,1.8,1.2", 1.0, SIDE, []),
}


def read_scatter(exr):
    """The `scatter` layer (H×W×3 float64) over the whole display window: oiiotool widens
    it and writes it as an uncompressed float scanline EXR, parsed here (header
    attributes, the line offset table, then per line y, size and the channels in name
    order, B G R)."""
    raw = exr + ".raw.exr"
    subprocess.run(
        ["oiiotool", exr, "--croptofull", "--ch", "scatter.R,scatter.G,scatter.B",
         "-d", "float", "--compression", "none", "--scanline", "-o", raw],
        check=True,
    )
    b = open(raw, "rb").read()
    os.remove(raw)
    assert b[:4] == b"\x76\x2f\x31\x01", "not an EXR"
    p, attrs = 8, {}
    while b[p] != 0:
        name_end = b.index(b"\0", p)
        type_end = b.index(b"\0", name_end + 1)
        size = int.from_bytes(b[type_end + 1:type_end + 5], "little")
        attrs[b[p:name_end].decode()] = b[type_end + 5:type_end + 5 + size]
        p = type_end + 5 + size
    p += 1
    x0, y0, x1, y1 = np.frombuffer(attrs["dataWindow"], "<i4")
    assert attrs["compression"] == b"\0", "compressed"
    w, h = x1 - x0 + 1, y1 - y0 + 1
    offsets = np.frombuffer(b, "<u8", count=h, offset=p)
    img = np.zeros((h, w, 3))
    for o in map(int, offsets):
        y = int.from_bytes(b[o:o + 4], "little", signed=True) - y0
        v = np.frombuffer(b, "<f4", count=3 * w, offset=o + 8).reshape(3, w)
        img[y] = v[::-1].T  # B, G, R → R, G, B
    return img


def fixture_path(fixture, out):
    """A fixture in fixtures/, or `gen:SIZE:SEED`: benches/make_cloud.py's cloud, written
    into `out` the first time (Debian's /usr/bin/python3 with pyopenvdb)."""
    if not fixture.startswith("gen:"):
        return os.path.join(ROOT, "fixtures", fixture)
    _, size, seed = fixture.split(":")
    path = os.path.join(out, f"fbm_{size}_{seed}.vdb")
    if not os.path.exists(path):
        subprocess.run(["/usr/bin/python3", os.path.join(ROOT, "benches", "make_cloud.py"), path,
                        "--size", size, "--seed", seed], check=True, stdout=subprocess.DEVNULL)
    return path


def render(murk, name, res, flags, out, tag, env_extra=None):
    fixture, sa, ss, scale, sun, extra = CASES[name]
    exr = os.path.join(out, f"{name}_{tag}.exr")
    args = [
        murk, "render", fixture_path(fixture, out), "-o", exr, "--quiet", "--float",
        "--res", res, "--sigma-a", str(sa), "--sigma-s", str(ss), "--density-scale", str(scale),
        "--light", f"sun:{sun[0]},{sun[1]},{sun[2]}:1,1,1:6",
    ] + extra + flags
    env = dict(os.environ)
    env.update(env_extra or {})
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(args, check=True, env=env)
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    img = read_scatter(exr)
    os.remove(exr)
    return img, cpu


def reference(murk, name, res, spp, out):
    path = os.path.join(out, f"path_{name}_{res}_{spp}.npz")
    if os.path.exists(path):
        z = np.load(path)
        return z["img"], float(z["noise"])
    t = time.time()
    h1, _ = render(murk, name, res, ["--scattering", "path", "--spp", str(spp), "--seed", "1"], out, "p1")
    h2, _ = render(murk, name, res, ["--scattering", "path", "--spp", str(spp), "--seed", "2"], out, "p2")
    img = 0.5 * (h1 + h2)
    noise = float(np.linalg.norm(h1 - h2) / 2 / max(np.linalg.norm(img), 1e-30))
    np.savez(path, img=img, noise=noise)
    print(f"  path {name}: {time.time() - t:.0f} s wall", file=sys.stderr, flush=True)
    return img, noise


def rel(got, want):
    return float(np.linalg.norm(got - want) / max(np.linalg.norm(want), 1e-30))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--murk", default=os.path.join(ROOT, "target/release/murk"))
    ap.add_argument("--out", default=os.path.join(tempfile.gettempdir(), "murk_check_fast"))
    ap.add_argument("--spp", type=int, default=256, help="spp of each path-traced half")
    ap.add_argument("--res", default="80x45")
    ap.add_argument("--only", default="")
    ap.add_argument("--fast-flags", default="--scattering fast")
    ap.add_argument("--single", action="store_true", help="also measure --scattering single")
    ap.add_argument("--env", default="", help="NAME=VALUE,... for the fast renders only")
    ap.add_argument("--json", default="")
    ap.add_argument(
        "--export",
        default="",
        help="CASE:FILE: write CASE's path-traced reference (the mean of the two halves) as "
        "little-endian f32 [row][column][RGB] (tests/fast_scattering.rs reads "
        "fixtures/path_white_x10_side.f32, made with --spp 1024 --res 80x45)",
    )
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    if a.export:
        name, path = a.export.split(":", 1)
        ref, noise = reference(a.murk, name, a.res, a.spp, a.out)
        ref.astype("<f4").tofile(path)
        print(f"{path}: {name} {ref.shape[1]}x{ref.shape[0]}, 2x{a.spp} spp, path noise {noise:.4f}")
        return
    env = dict(kv.split("=", 1) for kv in a.env.split(",") if kv)
    names = [n for n in CASES if not a.only or n in a.only.split(",")]
    rows = []
    print("| case | fast | path noise | fast net | fast/path mean | fast CPU s |" + (" single | single CPU s |" if a.single else ""))
    print("|---|---|---|---|---|---|" + ("---|---|" if a.single else ""))
    for name in names:
        ref, noise = reference(a.murk, name, a.res, a.spp, a.out)
        fast, t_fast = render(a.murk, name, a.res, a.fast_flags.split(), a.out, "fast", env)
        err = rel(fast, ref)
        net = float(np.sqrt(max(err * err - noise * noise, 0.0)))
        row = dict(case=name, fast=err, noise=noise, net=net,
                   ratio=float(fast.sum() / max(ref.sum(), 1e-30)), fast_cpu=t_fast)
        line = f"| {name} | {err:.3f} | {noise:.3f} | **{net:.3f}** | {row['ratio']:.3f} | {t_fast:.2f} |"
        if a.single:
            single, t_single = render(a.murk, name, a.res, ["--scattering", "single"], a.out, "single")
            row.update(single=rel(single, ref), single_cpu=t_single)
            line += f" {row['single']:.3f} | {t_single:.2f} |"
        rows.append(row)
        print(line, flush=True)
    worst = max(rows, key=lambda r: r["net"])
    print(f"worst net: {worst['case']} {worst['net']:.3f}; mean net {np.mean([r['net'] for r in rows]):.3f}")
    if a.json:
        json.dump(rows, open(a.json, "w"), indent=1)


if __name__ == "__main__":
    main()
