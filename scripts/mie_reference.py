"""Reference phase functions of water drops, computed with miepython (PyPI), for
murk's Lorenz-Mie code (src/integrate/phase/mie.rs; tests/mie_reference.rs).

Each case is the phase function of unpolarised light (per steradian, normalised over
the sphere) at one wavelength, averaged over the drop radii murk averages over:
the midpoints of RADIUS_SAMPLES equal sub-intervals of r0*[1 - SPREAD, 1 + SPREAD],
each standing for the same number of drops, so each contributes in proportion to its
scattering cross-section:

    p(theta) = sum_k (|S1|^2 + |S2|^2)_k / (2 pi sum_k x_k^2 Qsca_k)

The refractive index of water is Daimon & Masumura (2007), 20.0 C, written out here
independently of murk's code; murk's test checks it gives the same m.
"""
import math

import numpy as np
import miepython

SPREAD = 0.1
RADIUS_SAMPLES = 12

# (radius in micrometres, wavelength in nanometres): fog to rain, blue to red.
CASES = [(2.0, 450.0), (10.0, 550.0), (10.0, 700.0), (100.0, 405.0), (500.0, 655.0)]

# Scattering angles in degrees: the forward peak, the sky, both bows, the glory.
ANGLES_DEG = ([0.0, 0.002, 0.01, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 3.0, 5.0]
              + [10.0 * i for i in range(1, 13)]
              + [125.0, 128.0, 129.5, 130.0, 130.5, 131.0, 132.0, 134.0, 136.0, 137.0,
                 137.5, 138.0, 138.3, 138.6, 139.0, 139.5, 140.0, 141.0, 142.0, 144.0,
                 146.0, 150.0, 160.0, 170.0, 175.0, 178.0, 179.5, 180.0])


def water_index(lambda_nm):
    """Daimon & Masumura, Appl. Opt. 46, 3811 (2007), Table 3, 20.0 C (lambda in um)."""
    b = [5.684027565e-1, 1.726177391e-1, 2.086189578e-2, 1.130748688e-1]
    c = [5.101829712e-3, 1.821153936e-2, 2.620722293e-2, 1.069792721e1]
    l2 = (lambda_nm * 1e-3) ** 2
    return math.sqrt(1.0 + sum(bi * l2 / (l2 - ci) for bi, ci in zip(b, c)))


def radii(r0):
    k = RADIUS_SAMPLES
    return [r0 * (1.0 + SPREAD * (2.0 * (i + 0.5) / k - 1.0)) for i in range(k)]


def averaged_phase(m, lambda_nm, r0_um, mu):
    total = np.zeros(len(mu))
    norm = 0.0
    for r in radii(r0_um * 1e3):
        x = 2.0 * math.pi * r / lambda_nm
        # norm="one": (|S1|^2 + |S2|^2)/2 integrates to 1 over the sphere, so it is
        # the phase function; weight it by the cross-section (x^2 Qsca, fixed lambda).
        s1, s2 = miepython.S1_S2(m, x, mu, norm="one")
        _, qsca, _, _ = miepython.efficiencies_mx(m, x)
        total += x * x * qsca * (np.abs(s1) ** 2 + np.abs(s2) ** 2) / 2.0
        norm += x * x * qsca
    return total / norm


def reference():
    mu = np.cos(np.radians(ANGLES_DEG))
    cases = []
    for r0, lam in CASES:
        m = water_index(lam)
        p = averaged_phase(m, lam, r0, mu)
        cases.append({"radius_um": r0, "wavelength_nm": lam, "m": m,
                      "angles_deg": ANGLES_DEG, "phase": [float(v) for v in p]})
    return {"source": "miepython %s" % miepython.__version__,
            "radius_spread": SPREAD, "radius_samples": RADIUS_SAMPLES, "cases": cases}


if __name__ == "__main__":
    import json
    import time
    t = time.time()
    ref = reference()
    print(json.dumps(ref)[:600], time.time() - t)
