#!/usr/bin/python3
"""Helpers for scripts/bench.sh: alpha error of an EXR, run records, the final table.

    bench_report.py alpha IMAGE.exr OUT.fits         # A channel, full window, as FITS
    bench_report.py alpha-error REF.fits TEST.fits   # JSON: rmse, rmse_covered, max
    bench_report.py run OUT.json --time FILE [--murk-stats FILE] [--vdb-log FILE]
    bench_report.py table DIR                        # markdown table of DIR/*.json
    bench_report.py rel-rmse REF.exr TEST.exr [LAYER [K]]  # RMSE of TEST − REF over R,G,B
                                                     # (or LAYER.R/G/B; "" the beauty) ÷ the
                                                     # RMS of REF; K: REF is TEST's size / K

Every measurement is a JSON file DIR/<case>.<run>.json; `table` takes the median of
each field over a case's runs. Needs /usr/bin/python3 with numpy, and oiiotool.
"""

import glob
import json
import os
import re
import statistics
import subprocess
import sys

import numpy as np


# ---------------------------------------------------------------- images

def alpha(exr, fits):
    """Writes the A channel of `exr`, padded to its display window, as a float FITS file
    (the simplest float format this oiiotool writes)."""
    subprocess.run(["oiiotool", exr, "--ch", "A", "--croptofull", "-d", "float", "-o", fits],
                   check=True, stdout=subprocess.DEVNULL)


def rel_rmse(ref_exr, test_exr, layer="", sub=1):
    """RMSE of `test_exr` − `ref_exr` over the R, G, B channels (of `layer`, or the
    beauty), divided by the RMS of the reference's: one number for how much an image
    changed. With `sub` k > 1 (odd), the reference was rendered at 1/k of the test's
    size with the same camera: its pixel centres are the test's pixels (k/2, k/2) of
    every k × k block, which are compared."""
    sub = int(sub)
    import tempfile
    prefix = f"{layer}." if layer else ""
    num = den = 0.0
    with tempfile.TemporaryDirectory() as tmp:
        for c in "RGB":
            imgs = []
            for k, exr in enumerate((ref_exr, test_exr)):
                fits = os.path.join(tmp, f"{k}{c}.fits")
                subprocess.run(["oiiotool", exr, "--ch", prefix + c, "--croptofull", "-d", "float", "-o", fits],
                               check=True, stdout=subprocess.DEVNULL)
                imgs.append(read_fits(fits).astype(np.float64))
            if sub > 1:
                h, w = imgs[0].shape
                imgs[1] = imgs[1][sub // 2::sub, sub // 2::sub][:h, :w]
                if imgs[1].shape != imgs[0].shape:
                    raise ValueError(f"{test_exr} is not {sub}× {ref_exr}'s size")
            num += float(np.sum((imgs[1] - imgs[0]) ** 2))
            den += float(np.sum(imgs[0] ** 2))
    return float(np.sqrt(num / den)) if den > 0 else float(np.sqrt(num))


def read_fits(path):
    """A 2-D BITPIX −32 FITS image (header: 80-character cards in 2880-byte blocks)."""
    data = open(path, "rb").read()
    cards, end = {}, None
    for off in range(0, len(data), 80):
        card = data[off:off + 80].decode("ascii", "replace")
        if card.startswith("END") and card[3:].strip() == "":
            end = off + 80
            break
        if card[8:10] == "= ":
            cards[card[:8].strip()] = card[10:].split("/")[0].strip()
    if end is None or cards.get("BITPIX") != "-32" or cards.get("NAXIS") != "2":
        raise ValueError(f"{path}: not a 2-D float FITS image")
    start = (end + 2879) // 2880 * 2880
    w, h = int(cards["NAXIS1"]), int(cards["NAXIS2"])
    # OpenImageIO 2.4's writer puts one spurious row of zeros before the image (and does
    # not pad the data): skip it, or every row is read one too low and the top one lost.
    if len(data) - start == (h + 1) * w * 4:
        start += w * 4
    # FITS rows run bottom to top; images here are top to bottom.
    return np.flipud(np.frombuffer(data, dtype=">f4", count=w * h, offset=start).reshape(h, w))


def alpha_error(ref_fits, test_fits):
    ref, test = read_fits(ref_fits).astype(np.float64), read_fits(test_fits).astype(np.float64)
    if ref.shape != test.shape:
        raise ValueError(f"image sizes differ: {ref.shape} and {test.shape}")
    d = test - ref
    covered = (ref > 1e-3) | (test > 1e-3)
    return {
        "alpha_rmse": float(np.sqrt(np.mean(d * d))),
        "alpha_rmse_covered": float(np.sqrt(np.mean(d[covered] ** 2))) if covered.any() else 0.0,
        "alpha_max_err": float(np.max(np.abs(d))),
        "alpha_mean_err": float(np.mean(d)),
        "covered_pixels": int(covered.sum()),
    }


# ---------------------------------------------------------------- runs

def run_record(out, time_file, murk_stats=None, vdb_log=None, extra=None):
    """One render run: wall and CPU seconds and peak RSS (/usr/bin/time -f '%e %U %S %M'),
    and the renderer's own render-stage seconds."""
    real, user, sys_, rss_kb = (float(v) for v in open(time_file).read().split()[-4:])
    rec = {"wall_s": real, "cpu_s": user + sys_, "peak_rss_bytes": rss_kb * 1024}
    if murk_stats:
        st = json.load(open(murk_stats))
        rec["render_s"] = st["stages"]["render"]["seconds"]
        rec["samples"] = st.get("samples")
        sh = st["stages"].get("shadows", {})
        rec["bake_s"] = sh.get("seconds") if sh.get("status") == "ran" else None
        rec["map_bytes"] = st.get("shadow_map_memory_bytes") or None
        rec["density_bytes"] = st.get("density_memory_bytes") or None
        rec["total_s"] = st.get("total_seconds")
        for stage in ("load", "build", "shadows", "scatter", "render", "write"):
            sg = st["stages"].get(stage, {})
            if sg.get("status") == "ran":
                rec[f"stage_{stage}_s"] = sg.get("seconds")
        eb = st.get("error_budget")
        if eb:
            for k in ("step_voxels", "termination", "dsm_tolerance", "predicted_error", "pilot_seconds"):
                rec[f"budget_{k}"] = eb.get(k)
        maps = st.get("shadow_maps") or []
        if maps:
            m = maps[0]
            rec["map_bricks"] = m.get("bricks")
            rec["map_linear_bricks"] = m.get("linear_bricks")
            rec["map_dark_bricks"] = m.get("dark_bricks")
            rec["map_budget_stops"] = m.get("bricks_stopped_by_budget")
            if m.get("verify"):
                rec["dsm_max_error"] = m["verify"]["max_error"]
                rec["dsm_p99_error"] = m["verify"]["p99_error"]
    if vdb_log:
        # vdb_render -v prints "ray-tracing <grid>..." then "...completed in X sec".
        text = open(vdb_log).read()
        m = re.search(r"ray-tracing[^\n]*\n[^\n]*completed in ([0-9.e+-]+) sec", text)
        if not m:
            raise ValueError(f"{vdb_log}: no ray-tracing time in vdb_render -v output")
        rec["render_s"] = float(m.group(1))
    if extra:
        rec.update(json.load(open(extra)))
    json.dump(rec, open(out, "w"))


# ---------------------------------------------------------------- table

def load_cases(d):
    cases = {}
    for path in sorted(glob.glob(os.path.join(d, "*.json"))):
        case = os.path.basename(path).rsplit(".", 2)[0]
        cases.setdefault(case, []).append(json.load(open(path)))
    return cases


def med(cases, case, field):
    vals = [r[field] for r in cases.get(case, []) if r.get(field) is not None]
    return statistics.median(vals) if vals else None


def fmt(v, unit=""):
    if v is None:
        return "–"
    if unit == "MiB":
        return f"{v / 2**20:.1f} MiB"
    if unit == "s":
        return f"{v:.3f} s" if v < 10 else f"{v:.1f} s"
    if unit == "M/s":
        return f"{v / 1e6:.2f} M/s"
    if unit == "x":
        return f"{v:.2f}×"
    if isinstance(v, float):
        return "0" if v == 0 else (f"{v:.4f}" if abs(v) >= 1e-3 else f"{v:.1e}")
    return str(v)


def ratio(a, b):
    return a / b if a is not None and b else None


def load_table(cases):
    rows = []
    for kind in ("float", "half"):
        m, o = f"load-murk-{kind}", f"load-openvdb-{kind}"
        if m not in cases:
            continue
        for field, label, unit, target in (
            ("seconds", "wall", "s", "≤ 1.5×"),
            ("cpu_seconds", "CPU", "s", "≤ 1.5×"),
            ("peak_bytes", "peak RSS above baseline", "MiB", "≤ 1.5×"),
            ("retained_bytes", "RSS above baseline after load", "MiB", ""),
            ("structure_bytes", "structure (memory_bytes() / memUsage())", "MiB", ""),
        ):
            a, b = med(cases, m, field), med(cases, o, field)
            rows.append((f"load {kind}: {label}", fmt(a, unit), fmt(b, unit), fmt(ratio(a, b), "x"), target))
    for kind in ("float", "half"):
        s = f"sample-{kind}"
        if s not in cases:
            continue
        for what, key in (("random points", "points"), ("coherent rays, 0.5-voxel steps", "rays")):
            for label, mk in (("", "murk"), (", murk via &dyn Field", "murk_dyn")):
                a = med(cases, s, f"{mk}_{key}_per_s")
                b = med(cases, s, f"openvdb_rs_{key}_per_s")
                target = "≥ 5×" if key == "rays" and not label else ""
                rows.append((f"trilinear samples per CPU-second, 1 thread, {kind}, {what}{label}",
                             fmt(a, "M/s"), fmt(b, "M/s"), fmt(ratio(a, b), "x"), target))
        rows.append((f"largest sample difference murk − OpenVDB-rs, {kind}", fmt(med(cases, s, "max_abs_diff")), "", "", ""))
    return rows


def memory_table(cases):
    """#14 target 3: the large cloud's whole-process peak RSS against its density structure."""
    if "memory-large" not in cases:
        return []
    peak, dens = med(cases, "memory-large", "peak_rss_bytes"), med(cases, "memory-large", "density_bytes")
    return [("peak RSS, whole process", fmt(peak, "MiB"), fmt(dens, "MiB"), fmt(ratio(peak, dens), "x"), "≤ 3×",
             fmt(med(cases, "memory-large", "map_bytes"), "MiB"), fmt(med(cases, "memory-large", "cpu_s"), "s"))]


def render_table(cases, meta):
    rows = []
    steps = meta.get("steps", [])
    peers = (("vdb-default", "default"), ("vdb-matched", "matched"))
    configs = (
        ("murk-dsm", "murk --shadows dsm"),
        ("murk-march", "murk --shadows march"),
        ("murk-none", "murk --shadows none"),
        ("murk-maxerr", "murk --max-error 1e-2 (its own step, tolerance, termination)"),
        ("vdb-default", f"vdb_render -cutoff {meta.get('vdb_cutoff_default')} (its default)"),
        ("vdb-matched", f"vdb_render -cutoff {meta.get('vdb_cutoff_matched')} (termination matched)"),
        ("vdb-noshadow", "vdb_render -shadowstep 1000 (shadows all but off)"),
    )
    for step in steps:
        for key, label in configs:
            c = f"render-{key}-s{step}"
            if c not in cases:
                continue
            r = {f: med(cases, c, f) for f in ("render_s", "wall_s", "cpu_s", "alpha_rmse", "alpha_rmse_covered", "alpha_max_err")}
            vs = []
            for pk, _ in peers:
                p = f"render-{pk}-s{step}"
                if key.startswith("murk"):
                    rs = ratio(r["render_s"], med(cases, p, "render_s"))
                    rc = ratio(r["cpu_s"], med(cases, p, "cpu_s"))
                    vs.append(f"{fmt(rs, 'x')} (CPU {fmt(rc, 'x')})")
                else:
                    vs.append("")
            rows.append((step, label, fmt(r["render_s"], "s"), fmt(r["wall_s"], "s"), fmt(r["cpu_s"], "s"), *vs,
                         fmt(r["alpha_rmse"]), fmt(r["alpha_rmse_covered"]), fmt(r["alpha_max_err"])))
    for variant, what in (("converged", "fixtures/cloud.vdb"), ("converged-dilated", "topology dilated by 1 voxel")):
        c = f"render-vdb-{variant}"
        if c not in cases:
            continue
        r = {f: med(cases, c, f) for f in ("render_s", "wall_s", "cpu_s", "alpha_rmse", "alpha_rmse_covered", "alpha_max_err")}
        rows.append((meta.get("conv_step"),
                     f"convention check: vdb_render -cutoff {meta.get('vdb_cutoff_tiny')} -shadowstep 1000, {what} (1 run)",
                     fmt(r["render_s"], "s"), fmt(r["wall_s"], "s"), fmt(r["cpu_s"], "s"), "", "",
                     fmt(r["alpha_rmse"]), fmt(r["alpha_rmse_covered"]), fmt(r["alpha_max_err"])))
    return rows


def dsm_table(cases, meta):
    """The deep shadow map's targets: murk's whole run (load + bake + render + write)
    against vdb_render's, and the map's memory against the density structure's."""
    rows = []
    for step in meta.get("steps", []):
        vdb = f"render-vdb-default-s{step}"
        labels = {"murk-dsm": "murk --shadows dsm", "murk-march": "murk --shadows march",
                  "murk-none": "murk --shadows none",
                  "vdb-noshadow": "vdb_render -shadowstep 1000 (shadows all but off)"}
        for key, label in labels.items():
            c = f"render-{key}-s{step}"
            if c not in cases:
                continue
            wall, cpu = med(cases, c, "wall_s"), med(cases, c, "cpu_s")
            rows.append((step, label, fmt(med(cases, c, "bake_s"), "s"),
                         fmt(wall, "s"), fmt(med(cases, vdb, "wall_s"), "s"), fmt(ratio(wall, med(cases, vdb, "wall_s")), "x"),
                         fmt(ratio(cpu, med(cases, vdb, "cpu_s")), "x"), "≤ 0.10×" if key == "murk-dsm" else "",
                         fmt(med(cases, c, "peak_rss_bytes"), "MiB"), fmt(med(cases, vdb, "peak_rss_bytes"), "MiB"),
                         fmt(med(cases, c, "map_bytes"), "MiB"), fmt(med(cases, c, "density_bytes"), "MiB"),
                         fmt(ratio(med(cases, c, "map_bytes"), med(cases, c, "density_bytes")), "x"),
                         "≤ 2× (#14)" if key == "murk-dsm" else ""))
    return rows


def shadow_table(cases, meta):
    """Issue #14's shadow-map targets per cloud: the map's memory against the density
    structure's, the bake's share of the whole run, the lookups' share of the render
    stage (render with the map against `--shadows none`), and `--dsm-verify`'s max error."""
    rows = []
    tol = float(meta.get("dsm_tolerance", "1e-3"))
    for cloud in meta.get("shadow_clouds", []):
        dsm, none, ver = (f"shadow-{cloud}-{k}" for k in ("dsm", "none", "verify"))
        if dsm not in cases:
            continue
        mem, dens = med(cases, ver, "map_bytes"), med(cases, ver, "density_bytes")
        cpu = {k: med(cases, f"shadow-{cloud}-{k}", "cpu_s") for k in ("dsm", "none", "dsm-tiny", "none-tiny")}
        if None in cpu.values():
            continue
        bake = cpu["dsm-tiny"] - cpu["none-tiny"]
        r_dsm, r_none = cpu["dsm"] - cpu["dsm-tiny"], cpu["none"] - cpu["none-tiny"]
        lookups = (r_dsm - r_none) / r_dsm if r_dsm > 0 else None
        err = med(cases, ver, "dsm_max_error")
        share = lambda v: "–" if v is None else f"{100 * v:.0f} %"
        rows.append((cloud, meta.get("shadow_res", {}).get(cloud, ""),
                     f"{fmt(mem, 'MiB')} / {fmt(dens, 'MiB')} = {fmt(ratio(mem, dens), 'x')}", "≤ 2×",
                     f"{fmt(bake, 's')} of {fmt(cpu['dsm'], 's')} = {share(ratio(bake, cpu['dsm']))}", "≤ 25 %",
                     f"{fmt(r_dsm, 's')} vs {fmt(r_none, 's')} = {share(lookups)}", "≤ 30 %",
                     fmt(err), f"≤ {2 * tol:.0e}",
                     f"{med(cases, ver, 'map_bricks')} ({med(cases, ver, 'map_linear_bricks')} linear, "
                     f"{med(cases, ver, 'map_dark_bricks')} dark, {med(cases, ver, 'map_budget_stops')} stopped by budget)"))
    return rows


def speed_table(cases, meta):
    """#14 target 1 per cloud: whole processes against vdb_render's (its defaults), the
    alpha error of each against murk's --reference, murk's radiance error against its
    --reference in the same scattering mode, and whether the targets hold."""
    rows = []
    sizes = sorted({int(c.split("-")[1]) for c in cases if c.startswith("speed-")})
    res = dict(e.split(":") for e in meta.get("speed_clouds", "").split())
    labels = (
        ("vdb", "vdb_render (its defaults: step 1, shadow step 3, -cutoff 0.005)", None, None),
        ("maxerr-single", "murk --max-error 1e-2 --scattering single (as vdb_render)", 0.10, 1e-2),
        ("maxerr-fast", "murk --max-error 1e-2 (fast multiple scattering)", 0.10, 1e-2),
        ("default", "murk, no flags (fast multiple scattering, step 0.5)", 0.25, None),
    )
    for n in sizes:
        vdb = f"speed-{n}-vdb"
        v_cpu, v_alpha = med(cases, vdb, "cpu_s"), med(cases, vdb, "alpha_rmse")
        for key, label, target, max_err in labels:
            c = f"speed-{n}-{key}"
            if c not in cases:
                continue
            cpu, alpha_e = med(cases, c, "cpu_s"), med(cases, c, "alpha_rmse")
            rad = med(cases, c, "radiance_rel_rmse")
            r = ratio(cpu, v_cpu)
            stages = "–"
            if key != "vdb":
                parts = [(s, med(cases, c, f"stage_{s}_s")) for s in ("load", "build", "shadows", "scatter", "render", "write")]
                stages = ", ".join(f"{s} {v:.2f}" for s, v in parts if v is not None)
            chose = "–"
            if med(cases, c, "budget_step_voxels") is not None:
                tol = med(cases, c, "budget_dsm_tolerance")
                chose = (f"step {med(cases, c, 'budget_step_voxels'):.2f} vx, termination "
                         f"{fmt(med(cases, c, 'budget_termination'))}, tolerance {fmt(tol)}; "
                         f"pilot {fmt(med(cases, c, 'budget_pilot_seconds'), 's')}")
            verdict = ""
            if target is not None:
                ok_t = r is not None and r <= target
                ok_a = alpha_e is not None and v_alpha is not None and alpha_e <= v_alpha
                verdict = f"≤ {target:.2f}× " + ("met" if ok_t else "**NOT met**")
                if max_err is not None:
                    ok_r = rad is not None and rad <= max_err
                    verdict += (f"; alpha ≤ vdb_render's: {'yes' if ok_a else '**no**'}"
                                f"; radiance ≤ {max_err:g}: {'yes' if ok_r else '**no**'}")
            rows.append((f"{n}³, {res.get(str(n), '?')}", label, fmt(cpu, "s"), fmt(med(cases, c, "wall_s"), "s"),
                         fmt(r, "x") if key != "vdb" else "1", fmt(alpha_e), fmt(rad), verdict, chose, stages,
                         fmt(med(cases, c, "peak_rss_bytes"), "MiB")))
        for mode in ("single", "fast"):
            c = f"speed-{n}-ref-{mode}"
            if c in cases:
                rows.append((f"{n}³, {res.get(str(n), '?')}", f"{meta.get('speed_reference')}, --scattering {mode} "
                             "(the reference, 1 run)", fmt(med(cases, c, "cpu_s"), "s"), fmt(med(cases, c, "wall_s"), "s"),
                             "", "–", "0", "", "", "", fmt(med(cases, c, "peak_rss_bytes"), "MiB")))
    return rows


def print_table(header, rows):
    print("| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    for r in rows:
        print("| " + " | ".join(str(v) for v in r) + " |")
    print()


def emission_table(cases, meta):
    """Per fixture and scattering mode: the render with its emission against the same
    render without it (whole process CPU and wall, render stage, samples)."""
    rows = []
    names = sorted({c[len("emission-"):-len("-on")] for c in cases if c.startswith("emission-") and c.endswith("-on")})
    for name in names:
        on, off = f"emission-{name}-on", f"emission-{name}-off"
        fixture, scattering = name.rsplit("-", 1)
        cpu = ratio(med(cases, on, "cpu_s"), med(cases, off, "cpu_s"))
        rows.append((
            f"{fixture}.vdb", scattering,
            f"{fmt(med(cases, on, 'cpu_s'), 's')} / {fmt(med(cases, off, 'cpu_s'), 's')}",
            fmt(cpu, "x"),
            f"{fmt(med(cases, on, 'wall_s'), 's')} / {fmt(med(cases, off, 'wall_s'), 's')}",
            fmt(ratio(med(cases, on, "wall_s"), med(cases, off, "wall_s")), "x"),
            f"{fmt(med(cases, on, 'render_s'), 's')} / {fmt(med(cases, off, 'render_s'), 's')}",
            fmt(ratio(med(cases, on, "render_s"), med(cases, off, "render_s")), "x"),
            f"{fmt(med(cases, on, 'samples'))} / {fmt(med(cases, off, 'samples'))}",
            "≤ 1.5× " + ("met" if cpu is not None and cpu <= 1.5 else "NOT met"),
        ))
    return rows


def table(d):
    cases = load_cases(d)
    meta_path = os.path.join(d, "meta.info")
    meta = json.load(open(meta_path)) if os.path.exists(meta_path) else {}
    print(f"murk benchmarks, {meta.get('when', '')}. Medians of {meta.get('runs', '?')} runs on a SHARED "
          f"{meta.get('cores', '?')}-core machine (other builds were running): expect noise; CPU seconds are "
          "steadier than wall seconds there.")
    print()
    rows = load_table(cases)
    if rows:
        print("Load and sampling (murk against OpenVDB: pyopenvdb.readAll for loading, OpenVDB-rs's "
              "BoxSampler + ValueAccessor for sampling):")
        print()
        print_table(("measurement", "murk", "OpenVDB", "murk / OpenVDB", "target"), rows)
    rows = memory_table(cases)
    if rows:
        print(f"Memory on the large cloud (benches/make_cloud.py --size {meta.get('memory_size', '?')}), "
              "murk's defaults at 480x270: the process's peak RSS (/usr/bin/time) against the density "
              "structure (--stats density_memory_bytes).")
        print()
        print_table(("measurement", "murk", "density structure", "ratio", "target", "shadow map", "CPU"), rows)
    rows = render_table(cases, meta)
    if rows:
        print(f"Render of fixtures/cloud.vdb, {meta.get('res')}, {meta.get('threads')} threads; {meta.get('camera')}. "
              f"Alpha error against {meta.get('reference')}. Time ratios compare render stages "
              "(in brackets: process CPU seconds; target: murk --shadows march < 1× at equal or lower "
              "alpha error).")
        print()
        print_table(("step (voxels)", "renderer", "render stage", "wall", "CPU", "÷ vdb_render default",
                     "÷ vdb_render matched", "alpha RMSE", "alpha RMSE (covered px)", "alpha max err"), rows)
    rows = emission_table(cases, meta)
    if rows:
        print(f"Emission cost: each fixture rendered with its emission and without it (--emission-grid none "
              f"--temperature-grid none), back to back, {meta.get('emission_res')}, "
              f"{meta.get('emission_threads')} thread(s); load average at the end {meta.get('load', '?')}. "
              "Whole-process CPU (user+sys) and wall seconds, and the render stage (wall, from the stats); "
              "the target is on CPU.")
        print()
        print_table(("fixture", "scattering", "CPU with / without", "CPU ratio", "wall with / without",
                     "wall ratio", "render stage with / without", "ratio", "samples with / without",
                     "target"), rows)
    rows = dsm_table(cases, meta)
    if rows:
        print("Deep shadow map: whole processes (murk: load + bake + render + write) against vdb_render "
              "(default cutoff), wall time, CPU time and peak RSS; the map's memory against the density "
              "structure's.")
        print()
        print_table(("step (voxels)", "murk", "bake", "murk wall", "vdb_render wall", "wall ratio", "CPU ratio",
                     "target", "murk peak RSS", "vdb_render peak RSS", "map memory", "density memory",
                     "map / density", "target"), rows)
    print_shadow(cases, meta)
    rows = speed_table(cases, meta)
    if rows:
        print(f"#14 target 1: whole processes (murk: load + bake + multiple scattering + render + write), "
              f"{meta.get('threads')} threads, {meta.get('speed_camera')}; make_cloud.py's fBm cloud. Alpha RMSE of "
              f"every row against murk's {meta.get('speed_reference')} --scattering single; murk's radiance relative "
              "RMSE (R, G, B) against its reference in the same scattering mode. Stages: murk's wall seconds.")
        print()
        print_table(("cloud", "renderer", "CPU", "wall", "CPU ÷ vdb_render", "alpha RMSE", "radiance rel. RMSE",
                     "target", "--max-error chose", "stages (s)", "peak RSS"), rows)


def print_shadow(cases, meta):
    rows = shadow_table(cases, meta)
    if rows:
        print(f"Deep shadow map (#14 target 2), {meta.get('shadow_threads')} thread(s), murk's default camera "
              f"and medium, --dsm-tolerance {meta.get('dsm_tolerance')}, process CPU seconds: map memory against "
              "the density structure; bake (the 16x9 run with the map minus the one without) against the whole "
              "run; render stage (a run minus its 16x9 twin) with the map and with --shadows none, the "
              "difference (the lookups) against the first; --dsm-verify's max transmittance error "
              "(10,000 points, a separate run).")
        print()
        print_table(("cloud", "res", "map / density memory", "target", "bake CPU / total", "target",
                     "render stage CPU: dsm vs none = lookups", "target", "dsm-verify max", "target", "bricks"),
                    rows)


def main():
    cmd, args = sys.argv[1], sys.argv[2:]
    if cmd == "alpha":
        alpha(*args)
    elif cmd == "alpha-error":
        print(json.dumps(alpha_error(*args)))
    elif cmd == "run":
        out, opts = args[0], dict(zip(args[1::2], args[2::2]))
        run_record(out, opts["--time"], opts.get("--murk-stats"), opts.get("--vdb-log"), opts.get("--extra"))
    elif cmd == "rel-rmse":
        print(f"{rel_rmse(*args):.3g}")
    elif cmd == "table":
        table(args[0])
    else:
        sys.exit(f"unknown command {cmd}")


if __name__ == "__main__":
    main()
