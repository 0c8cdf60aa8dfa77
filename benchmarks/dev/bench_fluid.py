"""Work–precision of the fluid-driven particle motion (issue 6): error against a tight reference versus
CPU time, wall time, steps and force evaluations, for each DEM integrator over a range of time steps and
for the error-controlled ``adaptive_free_flight`` integrator over a range of tolerances.

    python benchmarks/run.py fluid [--quick] [--problems stokes,tanh,steel,entry,shear] [--out DIR]

Problems (one sphere, no contacts, docs/theory.md, *Fluid forces on a mass*; docs/validation.md, *Settling spheres*):

* ``stokes``  glass d = 0.1 mm in still water, Stokes drag + added mass, 5 tau; analytic
  ``v = v_t (1 - exp(-t/tau))``, ``tau = (rho_S + xi rho_F) d^2 / (18 mu)``;
* ``tanh``    steel d = 10 mm, constant C_D = 0.4, 1 s; analytic ``v = v_t tanh(g' t / v_t)``;
* ``steel``   steel d = 10 mm, standard curve (Clift–Gauvin), 1 s;
* ``entry``   steel d = 40 mm released 2 m above still water (air drag, crossing, water), 1.5 s;
* ``shear``   steel d = 20 mm thrown at 1 m/s across a horizontally sheared current ``u(y) = 0.5 y`` m/s
  (a frozen gridded snapshot; the depth-averaged field has no u(z), so the shear is across the
  current), sinking meanwhile, 0.5 s: drag and convective apparent mass on a grid.  Fluid torque is off
  here: with the report's small-particle rule its lever arms are the grid spacing (0.25 m) on a 20 mm
  sphere, a rotational damping so stiff that an explicit error-controlled scheme must take the contact
  step (measured: 50000 steps of 1e-5 s for 0.5 s).

References: the closed forms, otherwise scipy ``solve_ivp`` DOP853 (rtol 1e-12, atol 1e-14) on the same
force model (``breachflow.fluid.freeflight.FreeFlight``), solved in this run; its own error is estimated
against a DOP853 solve at rtol 1e-10 and printed.  Error = max over 20 output times of ``|v - v_ref|``
(3-vector) divided by ``max |v_ref|``.  Fixed-step runs: ``report``, ``velocity_verlet``,
``predicted_verlet`` with dt from 3e-3 s down to 1e-5 s (the report's step; ``--quick``: to 1e-4 s;
``stokes`` scales the range by tau).  Adaptive: ``adaptive_free_flight`` (``dopri5``, ``bs32``), rtol 1e-3
to 1e-10, atol = 1e-3 rtol.  The speed-up table interpolates each method's work at a target error
(log–log between the two runs bracketing it) and prints fixed-step work / adaptive work for the best
fixed-step integrator vs ``dopri5``.  Times are per process (CPU) and wall; on a shared machine the wall
times are noisy, CPU times and evaluation counts are the robust figures.
"""
from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np

G = 9.80665
RHO_W, STEEL, GLASS = 1000.0, 7800.0, 2500.0
N_OUT = 20
FIXED = ("report", "velocity_verlet", "predicted_verlet")
ADAPTIVE = ("dopri5", "bs32")
DTS = (3e-3, 1e-3, 3e-4, 1e-4, 3e-5, 1e-5)
RTOLS = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)


class Problem:
    """One sphere: initial state, force model, duration, and optionally an analytic v(t)."""

    def __init__(self, name, d, rho, pos, vel, duration, model_kwargs, exact=None, dt_scale=1.0):
        self.name, self.d, self.rho = name, d, rho
        self.pos, self.vel = np.array(pos, float), np.array(vel, float)
        self.duration, self.model_kwargs, self.exact, self.dt_scale = duration, model_kwargs, exact, dt_scale
        self.times = np.linspace(0.0, duration, N_OUT + 1)

    def state(self):
        from breachflow.dem import Material, ParticleState

        return ParticleState.spheres([self.pos], self.d / 2, Material(density=self.rho, kn=1e-6), vel=[self.vel])

    def model(self):
        from breachflow.fluid.forces import FluidForces

        kw = dict(self.model_kwargs)
        field = kw.pop("field")
        return FluidForces(field() if callable(field) else field, **{"velocity_profile": "uniform", **kw})


def problems():
    from breachflow.fluid.drag import DRAG_LAWS
    from breachflow.fluid.field import UniformWater
    from breachflow.field.sampling import uniform_snapshot

    mu, xi = RHO_W * 1e-6, 0.5
    d_s = 1e-4
    tau = (GLASS + xi * RHO_W) * d_s**2 / (18 * mu)
    v_st = (GLASS - RHO_W) * G * d_s**2 / (18 * mu)
    stokes_v = lambda t: np.stack([0 * t, 0 * t, -v_st * (1 - np.exp(-t / tau))], -1)  # noqa: E731
    d_t, cd = 0.01, 0.4
    gp = G * (STEEL - RHO_W) / (STEEL + xi * RHO_W)
    v_tt = math.sqrt(4 * G * d_t * (STEEL - RHO_W) / (3 * RHO_W * cd))
    tanh_v = lambda t: np.stack([0 * t, 0 * t, -v_tt * np.tanh(gp * t / v_tt)], -1)  # noqa: E731
    y = np.arange(-5.0, 5.0 + 1e-9, 0.25)
    shear = lambda: uniform_snapshot(6.0, u=0.5 * y[:, None], bed=-5.0, extent=(-5, 5, -5, 5), spacing=0.25)  # noqa: E731
    return {
        "stokes": Problem("stokes", d_s, GLASS, [0, 0, -1.0], [0, 0, 0], 5 * tau,
                          dict(field=0.0, air=None, xi=xi), exact=stokes_v, dt_scale=5 * tau),
        "tanh": Problem("tanh", d_t, STEEL, [0, 0, -10.0], [0, 0, 0], 1.0,
                        dict(field=0.0, air=None, xi=xi, drag_law=DRAG_LAWS.create("constant", value=cd)), exact=tanh_v),
        "steel": Problem("steel", 0.01, STEEL, [0, 0, -10.0], [0, 0, 0], 1.0,
                         dict(field=0.0, air=None, xi=xi, drag_law="clift_gauvin")),
        "entry": Problem("entry", 0.04, STEEL, [0, 0, 2.02], [0, 0, 0], 1.5,
                         dict(field=lambda: UniformWater(surface=0.0), xi=xi, drag_law="clift_gauvin")),
        "shear": Problem("shear", 0.02, STEEL, [0, -1.0, -0.5], [0, 1.0, 0], 0.5,
                         dict(field=shear, air=None, xi=xi, drag_law="clift_gauvin", torque=False)),
    }


def reference(p: Problem, rtol=1e-12, atol=1e-14):
    """Velocities (T, 3) at the output times: analytic, else DOP853 on the package's force model."""
    if p.exact is not None:
        return p.exact(p.times)
    from scipy.integrate import solve_ivp

    from breachflow.dem.forces import Gravity
    from breachflow.fluid.freeflight import FreeFlight

    st = p.state()
    rhs = FreeFlight(st, [Gravity(), p.model()])
    y0 = np.hstack([st.pos, st.vel, st.omega]).ravel()
    sol = solve_ivp(lambda t, y: rhs(t, y.reshape(1, 9)).ravel(), (0.0, p.duration), y0, method="DOP853",
                    t_eval=p.times, rtol=rtol, atol=atol)
    if not sol.success:
        raise RuntimeError(f"reference solve of {p.name} failed: {sol.message}")
    return sol.y.T[:, 3:6]


def run_dem(p: Problem, integrator, dt):
    """Run through DemSimulation; returns (velocities (T, 3), cpu s, wall s, steps, force evaluations)."""
    from breachflow.dem import DemSimulation

    variable = not isinstance(integrator, str)
    per = None
    if not variable:  # a whole number of steps between outputs: dt is rounded to hit the output times
        per = max(1, int(round((p.times[1] - p.times[0]) / dt)))
        dt = (p.times[1] - p.times[0]) / per
    model = p.model()
    st = p.state()
    sim = DemSimulation(st, models=[model], integrator=integrator, dt=dt, sleeping=False)
    out = np.empty((p.times.size, 3))
    out[0] = st.vel[0]
    c0, w0 = time.process_time(), time.perf_counter()
    for k in range(1, p.times.size):
        if variable:
            sim.run(p.times[k] - sim.t)
        else:
            sim.step(per)
        out[k] = st.vel[0]
    return out, time.process_time() - c0, time.perf_counter() - w0, sim.steps, model.evaluations


def error(v, ref):
    return float(np.max(np.linalg.norm(v - ref, axis=1)) / np.max(np.linalg.norm(ref, axis=1)))


def work_at(rows, target, key):
    """Work of a method at error *target*: log–log interpolation between the bracketing runs (NaN if the
    method never reaches it; the cheapest run's work if even that one is below the target)."""
    pts = sorted((r[key], r["error"]) for r in rows if r["error"] > 0 and r[key] > 0)
    for i, (w, e) in enumerate(pts):
        if e <= target:
            if i == 0:
                return w
            (w0, e0) = pts[i - 1]
            if e0 <= e:
                return w
            f = (math.log(target) - math.log(e0)) / (math.log(e) - math.log(e0))
            return math.exp(math.log(w0) + f * (math.log(w) - math.log(w0)))
    return math.nan


def main(argv):
    ap = argparse.ArgumentParser(prog="bench fluid")
    ap.add_argument("--quick", action="store_true", help="time steps only down to 1e-4 s")
    ap.add_argument("--problems", default="stokes,tanh,steel,entry,shear")
    ap.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "results"))
    args = ap.parse_args(argv)
    from breachflow.coupling.integrators import AdaptiveFreeFlight

    probs = problems()
    names = [n.strip() for n in args.problems.split(",") if n.strip()]
    dts = [d for d in DTS if not (args.quick and d < 1e-4)]
    # compile the kernels once (not timed)
    warm = probs["shear"]
    for name in FIXED:
        run_dem(Problem("warm", warm.d, warm.rho, warm.pos, warm.vel, 0.01, warm.model_kwargs), name, 1e-3)
    results = {}
    print(f"{'problem':8} {'method':18} {'dt / rtol':>10} {'error':>10} {'steps':>8} {'force evals':>11} "
          f"{'CPU s':>8} {'wall s':>8}")
    for pname in names:
        p = probs[pname]
        ref = reference(p)
        if p.exact is None:
            print(f"{pname:8} reference DOP853 rtol 1e-12: differs from rtol 1e-10 by "
                  f"{error(reference(p, 1e-10, 1e-12), ref):.2e} (relative)")
        rows = []
        for name in FIXED:
            for dt in dts:
                v, cpu, wall, steps, evals = run_dem(p, name, dt * p.dt_scale)
                rows.append(dict(method=name, param=dt * p.dt_scale, error=error(v, ref), steps=steps, evals=evals,
                                 cpu=cpu, wall=wall))
        for method in ADAPTIVE:
            for rtol in RTOLS:
                integ = AdaptiveFreeFlight(method=method, rtol=rtol, atol=1e-3 * rtol)
                v, cpu, wall, steps, evals = run_dem(p, integ, 1e-5 * p.dt_scale)
                rows.append(dict(method=f"adaptive {method}", param=rtol, error=error(v, ref), steps=steps,
                                 evals=evals, cpu=cpu, wall=wall))
        for r in rows:
            print(f"{pname:8} {r['method']:18} {r['param']:10.2e} {r['error']:10.2e} {r['steps']:8d} {r['evals']:11d} "
                  f"{r['cpu']:8.3f} {r['wall']:8.3f}")
        results[pname] = rows
    print(flush=True)
    print("Speed-up of adaptive_free_flight (dopri5) over the best fixed-step DEM integrator at equal error", flush=True)
    print("(fixed work / adaptive work; 'report@dt_min' = the error of the report scheme at the smallest dt, 1e-5 s except stokes)", flush=True)
    print(f"{'problem':8} {'target':>12} {'best fixed':>17} {'steps x':>9} {'evals x':>9} {'CPU x':>8} {'wall x':>8}", flush=True)
    for pname, rows in results.items():
        by = {}
        for r in rows:
            by.setdefault(r["method"], []).append(r)
        targets = [(f"{t:.0e}", t) for t in (1e-3, 1e-5)]
        rep = [r for r in by["report"] if abs(r["param"] - 1e-5 * probs[pname].dt_scale) < 1e-12]
        if rep:
            targets.append(("report@dt_min", rep[0]["error"]))
        for label, target in targets:
            best = min(FIXED, key=lambda m: _nan_inf(work_at(by[m], target, "evals")))
            ratios = [work_at(by[best], target, k) / work_at(by["adaptive dopri5"], target, k)
                      for k in ("steps", "evals", "cpu", "wall")]
            print(f"{pname:8} {label:>12} {best:>17} " + " ".join(f"{x:8.1f}x" if np.isfinite(x) else f"{'n/a':>9}"
                                                                   for x in ratios))
    path = plot(results, Path(args.out))
    print(f"\nwork–precision plot: {path}", flush=True)
    return 0


def _nan_inf(x):
    return math.inf if not np.isfinite(x) else x


def plot(results, out: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out.mkdir(parents=True, exist_ok=True)
    names = list(results)
    fig, axes = plt.subplots(2, len(names), figsize=(3.6 * len(names), 6.5), dpi=110, squeeze=False)
    styles = {"report": "o-", "velocity_verlet": "s-", "predicted_verlet": "^-",
              "adaptive dopri5": "D--", "adaptive bs32": "v--"}
    for j, pname in enumerate(names):
        by = {}
        for r in results[pname]:
            by.setdefault(r["method"], []).append(r)
        for i, (key, label) in enumerate((("cpu", "CPU time (s)"), ("evals", "force evaluations"))):
            ax = axes[i, j]
            for m, rows in by.items():
                ax.loglog([r[key] for r in rows], [max(r["error"], 1e-16) for r in rows], styles.get(m, "x-"),
                          ms=3, label=m)
            ax.set_xlabel(label)
            ax.grid(alpha=0.3, which="both")
            if j == 0:
                ax.set_ylabel("max relative velocity error")
            if i == 0:
                ax.set_title(pname)
    axes[0, 0].legend(fontsize=7)
    fig.suptitle("Work–precision: DEM integrators (dt sweep) vs adaptive free flight (rtol sweep)", fontsize=10)
    fig.tight_layout()
    path = out / "fluid_work_precision.png"
    fig.savefig(path)
    plt.close(fig)
    return path
