"""How many Gauss–Legendre points the drag's profile average needs (issue 16, ``fluid/profile.py``).

    python3 tasks.py shell python benchmarks/bench_drag_points.py [--cases 400] [--points 3,4,5,6,8,10,12,16]

:func:`breachflow.fluid.profile.drag_factor` averages ``f|f|`` of the vertical profile over a sphere's
wetted projected area with a fixed rule (:func:`~breachflow.fluid.profile.drag_factor_rule`). For each
point count this prints the largest and the median relative error of the factor against
``scipy.integrate.quad`` (epsrel 1e-11, split at the log law's ``z0``) over random cases in four phases
(resting on / pressed up to 2 % of r into the bed; straddling the surface; inside the water; anywhere,
also above it), h 0.3–10 m, r 0.05–3 m, k_s 0.066 m, 0.005–0.5 m and 2r, for the log and power profiles,
and the CPU ns per call (median of 5 repeats over the cases, min–max) with the point value
``profile_factor`` at the centre as the baseline measured in the same run.
"""
from __future__ import annotations

import argparse
import math
import sys
import time

import numpy as np


def cases(n, seed=1):
    rng = np.random.default_rng(seed)
    out = []
    for k in range(n):
        h = rng.uniform(0.3, 10.0)
        r = rng.uniform(0.05, 0.5) if k % 2 else rng.uniform(0.5, 3.0)
        ks = (0.066, rng.uniform(0.005, 0.5), 2.0 * r)[k % 3]
        mode = (k // 3) % 4
        zc = (r - rng.uniform(0.0, 0.02 * r), h + rng.uniform(-r, r), rng.uniform(r, max(r, h - r)),
              rng.uniform(-0.5 * r, h + 0.9 * r))[mode]
        out.append((zc, r, h, ks))
    return np.array(out)


def reference(code, zc, r, h, ks):
    from scipy.integrate import quad

    from breachflow.fluid.profile import profile_factor

    lo, hi = max(0.0, zc - r), min(h, zc + r)
    w = lambda z: 2.0 * math.sqrt(max(r * r - (z - zc) ** 2, 0.0))  # noqa: E731
    g = lambda z: profile_factor(code, z, h, ks) ** 2 * w(z)  # noqa: E731
    pts = [ks / 30.0] if code == 1 and lo < ks / 30.0 < hi else None
    num = quad(g, lo, hi, points=pts, limit=500, epsabs=0.0, epsrel=1e-11)[0]
    return math.sqrt(num / quad(w, lo, hi, limit=500, epsabs=0.0, epsrel=1e-11)[0])


def main(argv) -> int:
    import numba

    from breachflow.fluid.profile import DRAG_POINTS, drag_factor_rule, profile_factor

    ap = argparse.ArgumentParser(prog="bench_drag_points")
    ap.add_argument("--cases", type=int, default=400)
    ap.add_argument("--points", default="3,4,5,6,8,10,12,16")
    a = ap.parse_args(argv)
    c = cases(a.cases)
    wet = (np.minimum(c[:, 2], c[:, 0] + c[:, 1]) > np.maximum(0.0, c[:, 0] - c[:, 1]))
    c = c[wet]
    refs = {code: np.array([reference(code, *row) for row in c]) for code in (1, 2)}

    @numba.njit
    def rule_all(code, c, t, w, out):
        for i in range(c.shape[0]):
            zc, r, h, ks = c[i, 0], c[i, 1], c[i, 2], c[i, 3]
            out[i] = drag_factor_rule(code, max(0.0, zc - r), min(h, zc + r), zc, r, h, ks, t, w)

    @numba.njit
    def point_all(code, c, out):
        for i in range(c.shape[0]):
            out[i] = profile_factor(code, c[i, 0], c[i, 2], c[i, 3])

    print(f"{len(c)} wetted cases; the shipped rule has {DRAG_POINTS} points")
    out = np.empty(len(c))
    point_all(1, c, out)
    rows = []
    for n in [int(s) for s in a.points.split(",") if s]:
        t, w = np.polynomial.legendre.leggauss(n)
        errs = {}
        for code in (1, 2):
            rule_all(code, c, t, w, out)
            ok = refs[code] > 1e-3
            e = np.abs(out[ok] / refs[code][ok] - 1.0)
            errs[code] = (e.max(), np.median(e))
        rows.append((n, t, w, errs))
    reps = 200
    times = {"point": []} | {n: [] for n, *_ in rows}
    for _ in range(5):  # interleaved repeats
        c0 = time.process_time()
        for _ in range(reps):
            point_all(1, c, out)
        times["point"].append((time.process_time() - c0) / (reps * len(c)) * 1e9)
        for n, t, w, _ in rows:
            c0 = time.process_time()
            for _ in range(reps):
                rule_all(1, c, t, w, out)
            times[n].append((time.process_time() - c0) / (reps * len(c)) * 1e9)
    tp = times["point"]
    print(f"point value at the centre (log): {np.median(tp):.0f} ns/call ({min(tp):.0f}-{max(tp):.0f})")
    print("points | log: max rel err, median | power: max rel err, median | log ns/call (min-max)")
    for n, _, _, errs in rows:
        tn = times[n]
        print(f"{n:6d} | {errs[1][0]:.2e}, {errs[1][1]:.1e} | {errs[2][0]:.2e}, {errs[2][1]:.1e} | "
              f"{np.median(tn):.0f} ({min(tn):.0f}-{max(tn):.0f})")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
