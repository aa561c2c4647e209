#!/usr/bin/env python3
"""Measures the deep shadow map against exact shadow rays on the fixtures and prints the
two markdown tables docs/how-it-works.md's "How exact the map is" shows.

Runs `murk render --dsm-verify` (10,000 random points inside the density) for each
fixture, sun and tolerance, at a tiny image size: the map and its verification do not
depend on the image. Usage: scripts/dsm_verify.py [path/to/murk]
"""

import json
import math
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MURK = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "target", "release", "murk")
FIXTURES = ["cloud", "levelset_fog", "pyro"]


def verify(fixture, light, tolerance):
    with tempfile.TemporaryDirectory() as tmp:
        stats = os.path.join(tmp, "stats.json")
        subprocess.run(
            [MURK, "render", os.path.join(ROOT, "fixtures", fixture + ".vdb"),
             "-o", os.path.join(tmp, "out.exr"), "--res", "16x9", "--quiet",
             "--light", light, "--dsm-tolerance", str(tolerance),
             "--dsm-verify", "--stats", stats],
            check=True)
        with open(stats) as f:
            s = json.load(f)
    m = s["shadow_maps"][0]
    return m, s["density_memory_bytes"]


def mib(b):
    return "%.2f" % (b / 2**20)


def main():
    print("  | fixture | light | `--dsm-tolerance` | mean | p99 | max | points over | "
          "map / density memory | bake |")
    print("  |---|---|---|---|---|---|---|---|---|")
    cases = [("sun:0.6,1,0.5", 5e-3), ("sun:0.6,1,0.5", 1e-3), ("sun:0.6,1,0.5", 1e-4),
             ("sun:0,1,0", 1e-3), ("point:3,2,1", 1e-3)]
    for fixture in FIXTURES:
        for light, tol in cases:
            m, dens = verify(fixture, light + ":1,1,1:6", tol)
            v = m["verify"]
            print("  | %s | %s | %g | %.1e | %.1e | %.1e | %d | %s / %s MiB (%.1f×) | %.2f s |" % (
                fixture, light, tol, v["mean_error"], v["p99_error"], v["max_error"],
                v["over_tolerance"], mib(m["memory_bytes"]), mib(dens),
                m["memory_bytes"] / dens, m["bake_seconds"]))
    print()
    print("  | sun | angle to the faces | " + " | ".join(
        "%s: max (points over)" % f for f in FIXTURES) + " |")
    print("  |---|---|" + "---|" * len(FIXTURES))
    for eps in [0.01, 0.03, 0.1, 0.2, 0.35]:
        angle = math.degrees(math.asin(eps / math.sqrt(0.36 + 1 + eps * eps)))
        cells = []
        for fixture in FIXTURES:
            v = verify(fixture, "sun:0.6,1,%g:1,1,1:6" % eps, 1e-3)[0]["verify"]
            cells.append("%.1e (%d)" % (v["max_error"], v["over_tolerance"]))
        print("  | 0.6,1,%g | %.1f° | %s |" % (eps, angle, " | ".join(cells)))


if __name__ == "__main__":
    main()
