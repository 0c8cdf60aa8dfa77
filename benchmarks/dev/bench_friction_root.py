"""The cube root of the shallow-water friction term: ``h ** (1/3)`` against its alternatives.

    python3 tasks.py bench friction_root [--cells 4000000] [--repeats 5]

The implicit Manning friction of the SWE update (``breachflow.swe.step._update``) needs
``h^(7/3) = h² h^(1/3)`` once per wet cell and stage. Timed here in a compiled loop over random depths
(0.5-10 m, a branch per cell as in the kernel so that the loop is not vectorised): ``pow`` (``h ** (1.0 / 3.0)``,
the kernel's expression), ``cbrt`` (``np.cbrt``, libm's cube root), ``newton`` (one Newton step from a
cached root of a depth 1e-4 relative away, the "cache per cell" idea: ``c' = (2c + h / c²) / 3``) and
``none`` (``h³`` instead, the loop without a root: the floor). Printed: ns per cell (median of the
repeats, with min-max), the ratio to ``pow`` and the largest relative difference from ``pow`` (the error
figure: 0 or 1 ulp is round-off).
"""
from __future__ import annotations

import argparse
import statistics as st
import time

import numpy as np


def kernels():
    import numba

    @numba.njit(cache=False)
    def k_pow(h, c, out):
        for i in range(h.size):
            x = h[i]
            out[i] = x ** (1.0 / 3.0) if x > 0.5 else x

    @numba.njit(cache=False)
    def k_cbrt(h, c, out):
        for i in range(h.size):
            x = h[i]
            out[i] = np.cbrt(x) if x > 0.5 else x

    @numba.njit(cache=False)
    def k_newton(h, c, out):
        for i in range(h.size):
            x = h[i]
            if x > 0.5:
                r = c[i]
                out[i] = (2.0 * r + x / (r * r)) * (1.0 / 3.0)
            else:
                out[i] = x

    @numba.njit(cache=False)
    def k_none(h, c, out):
        for i in range(h.size):
            x = h[i]
            out[i] = x * x * x if x > 0.5 else x

    return {"pow": k_pow, "cbrt": k_cbrt, "newton": k_newton, "none": k_none}


def main(argv) -> int:
    ap = argparse.ArgumentParser(prog="bench friction_root")
    ap.add_argument("--cells", type=int, default=4_000_000)
    ap.add_argument("--repeats", type=int, default=5)
    a = ap.parse_args(argv)
    rng = np.random.default_rng(1)
    h = rng.uniform(0.5, 10.0, a.cells)
    cached = (h * (1.0 + 1e-4)) ** (1.0 / 3.0)  # the root of the previous step's depth
    ks = kernels()
    outs = {k: np.empty_like(h) for k in ks}
    for k, f in ks.items():
        f(h[:10], cached[:10], outs[k][:10])
    times = {k: [] for k in ks}
    for _ in range(a.repeats):  # interleaved: load drifts on a shared machine
        for k, f in ks.items():
            c0 = time.process_time()
            f(h, cached, outs[k])
            times[k].append((time.process_time() - c0) / h.size * 1e9)
    ref = outs["pow"]
    base = st.median(times["pow"])
    print(f"{a.cells} cells, {a.repeats} repeats (CPU time per cell)")
    for k in ks:
        m = st.median(times[k])
        err = "-" if k == "none" else f"{np.max(np.abs(outs[k] - ref) / ref):.2e}"
        print(f"  {k:7s} {m:6.2f} ns ({min(times[k]):.2f}-{max(times[k]):.2f}), ratio to pow {m / base:.3f}, "
              f"max relative difference from pow {err}")
    return 0


if __name__ == "__main__":
    import sys

    sys.exit(main(sys.argv[1:]))
