"""Cost of the DEM contact kernels per listed pair against a bare Hooke normal-force loop, and of each pass
of a compiled step (issue 16).

    python3 tasks.py bench dem_kernel [--scene bed|pour] [--n 1000] [--calls 2000] [--reps 5] [--old <src>]
    python3 tasks.py bench dem_kernel --phases [--scene bed|pour] [--n 1000] [--calls 300] [--reps 3]
    python3 tasks.py bench dem_kernel --compile [--old <src>]
    python3 tasks.py bench dem_kernel --steps-ab --old <src> [--scene bed|pour] [--n 1000] [--steps 2000] [--reps 3]

On the settled bed (or the poured pile) of benchmarks/bench_dem.py (n spheres), times
``contacts.pair_forces_interval`` with the step-averaged law as ``predicted_verlet`` (dashpots at predicted
velocities) and ``velocity_verlet`` call it, and with ``contact_law = "hooke_history"`` (LAMMPS'
point-evaluated law), in CPU ns per listed pair; ``contacts.plane_forces`` (the floor) in ns per particle;
and a loop over the same pair list that only adds ``k_N overlap`` along the normal (what any contact code
must do at least). Each kernel is called ``--calls`` times inside one compiled loop, the pair and plane
kernels each time from the same saved contact histories (copied in before each call, the copies' time
subtracted: otherwise the histories grow at the fixed positions to the slip limit and the kernel times another
branch mix than a step has); best and median of ``--reps``, interleaved in alternating order. ``--old <src>``: the same kernels of another source tree
(``dem/contacts.py`` with the ``dem`` modules it imports, under another package name), timed
in the same process, with the old/new ratios (best, and mean ± sd of the paired repeats; identical trees
give 0.97-1.05 on this loaded machine).

``--phases``: the cost of each pass of one step of the compiled loop (``dem/steploop.py::verlet_steps``)
in CPU ns per particle: every kernel is called ``--calls`` times inside one compiled loop (no dispatch
cost) on its own copy of the arrays it writes (the pair and plane kernels from the saved histories each call,
as above), best of ``--reps``: the separate passes (as the Python step
runs them) and the compiled loop's fused ``first_pass`` / ``second_pass`` (gravity, damping when a coefficient is not
0, closing kick); the compiled loop's sum (pair and plane forces, the fused passes, the step statistics) is
set against the whole step measured with ``sim.step`` (the rest: dispatch, neighbour-list rebuilds,
events), and one rebuild is timed.

``--steps-ab``: whole steps (``sim.step``) of this tree and --old's from the same start, in fresh processes
(``PYTHONPATH`` selects the tree, each tree its own numba cache), old and new interleaved, in the three modes
of ``bench dem``: ``velocity_verlet`` and ``predicted_verlet`` with the step-averaged law and
``velocity_verlet`` with ``hooke_history``; particle-steps per CPU second, mean ± sd, and the new/old ratio
of paired runs (as ``benchmarks/bench_dem_ab.py``, which has no ``hooke_history`` mode).
"""
from __future__ import annotations

import argparse
import math
import statistics as st
import sys
import time
from pathlib import Path

import numba
import numpy as np


@numba.njit(cache=True, error_model="numpy")
def bare_hooke(pa, pb, pos, radius, kn, geom, periodic, force):
    """Normal spring only: the floor cost of a pair loop over the same list."""
    nc = 0
    for p in range(pa.shape[0]):
        i = pa[p]
        j = pb[p]
        dx = pos[j, 0] - pos[i, 0]
        dy = pos[j, 1] - pos[i, 1]
        if periodic[0]:
            dx -= geom[6] * math.floor(dx / geom[6] + 0.5)
        if periodic[1]:
            dy -= geom[7] * math.floor(dy / geom[7] + 0.5)
        dz = pos[j, 2] - pos[i, 2]
        dist = math.sqrt(dx * dx + dy * dy + dz * dz)
        ov = radius[i] + radius[j] - dist
        if ov <= 0.0:
            continue
        f = -kn * ov / dist
        force[i, 0] += f * dx
        force[i, 1] += f * dy
        force[i, 2] += f * dz
        force[j, 0] -= f * dx
        force[j, 1] -= f * dy
        force[j, 2] -= f * dz
        nc += 1
    return nc


@numba.njit
def _repeat(calls, fn, args):
    """Call fn(*args) *calls* times inside compiled code."""
    for _ in range(calls):
        fn(*args)


@numba.njit
def _repeat_reset(calls, fn, args, h, h0):
    """Call fn(*args) *calls* times, each from the saved contact histories: *h* (one of *args*' arrays) is set
    to *h0* before each call. Without it the same positions are evaluated again and again and the shear
    histories grow by g_S dt each call, to the slip limit: on the 1000-sphere bed 2388 of 2400 contacts of the
    step-averaged law slip after 1000 calls, against 353 in a real step, and the timed kernel runs another
    branch mix than a step's."""
    for _ in range(calls):
        h[:] = h0
        fn(*args)


@numba.njit
def _copy_only(calls, h, h0):
    """The history copies of :func:`_repeat_reset` alone (subtracted from its time)."""
    for _ in range(calls):
        h[:] = h0


def _timed(calls, fn, args, reset):
    """CPU s per call of fn(*args): with *reset* = (h, h0), from the saved histories each call (the copies'
    own time subtracted)."""
    if reset is None:
        c = time.process_time()
        _repeat(calls, fn, args)
        return (time.process_time() - c) / calls
    c = time.process_time()
    _repeat_reset(calls, fn, args, *reset)
    t = time.process_time() - c
    c = time.process_time()
    _copy_only(calls, *reset)
    return (t - (time.process_time() - c)) / calls


def _writable(args):
    """The arguments with their arrays copied (each timed kernel writes into its own copies)."""
    return tuple(a.copy() if isinstance(a, np.ndarray) else a for a in args)


def phases(a) -> int:
    """Per-pass CPU cost of a step of the compiled Verlet loop (see the module docstring)."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/, for the published benchmarks' helpers
    import bench_dem

    import importlib

    from breachflow.dem import forces, steploop
    from breachflow.dem import pair_contacts as contacts

    integrators = importlib.import_module("breachflow.dem.integrators")  # the package exports the registry

    sim0, L = bench_dem.settled_bed(a.n) if a.scene == "bed" else bench_dem.poured_pile(a.n)
    s0 = sim0.state
    for integ, law in (("predicted_verlet", "step_averaged"), ("velocity_verlet", "step_averaged"),
                       ("velocity_verlet", "hooke_history")):
        sim = bench_dem.make_sim(s0.pos.copy(), s0.vel.copy(), L, integ, omega=s0.omega.copy(), law=law)
        sim.step(20)
        c = time.process_time()
        sim.step(a.steps)
        whole = (time.process_time() - c) / a.steps / sim.state.n * 1e9
        sim.pairs.rebuild()
        s, w, it, dt = sim.state, sim.work, sim.integrator, sim.dt
        idx = sim.idx
        n = idx.size
        h = 0.5 * dt
        lo, hi = it.force_interval[0] * dt, it.force_interval[1] * dt
        pl = sim.boundaries[0]
        pred = bool(it.predict_velocity)
        wake = (sim.sleepers.wake_flag, sim.sleepers.wake_ids, np.zeros(1, np.int64))
        ve, we = (w["v"], w["w"]) if pred else (s.vel, s.omega)
        if pred:
            integrators.predict_extrapolated(idx, s.vel, s.omega, sim.force, sim.torque, w["fp"].copy(),
                                             w["tp"].copy(), sim._inv_m, sim._inv_i, h, it.extrapolate,
                                             sim.lmask, sim.rmask, ve, we)
        box = (sim.geom, sim.periodic, sim._box, sim._use_box, s.active.copy(), s.awake.copy(), sim._tmp_ids)
        ph = {
            "displacement check": (contacts.displacement_since, (idx, s.pos, sim.pairs.pos_build, sim.geom, sim.periodic)),
            "kick": (integrators.kick, (idx, s.vel, s.omega, sim.force, sim.torque, sim._inv_m, sim._inv_i, h,
                                        sim.lmask, sim.rmask)),
            "drift": (integrators.drift, (idx, s.pos, s.vel, dt)),
            "wrap_and_check": (contacts.wrap_and_check, (idx, s.pos, s.vel, s.omega) + box),
        }
        if pred:
            ph["predict"] = (integrators.predict_extrapolated,
                             (idx, s.vel, s.omega, sim.force, sim.torque, w["fp"], w["tp"], sim._inv_m, sim._inv_i,
                              h, it.extrapolate, sim.lmask, sim.rmask, w["v"], w["w"]))
        ph["zero_rows"] = (forces.zero_rows, (idx, sim.force, sim.torque))
        ph["pair forces"] = (contacts.pair_forces_interval,
                             (sim.pairs.pa, sim.pairs.pb, sim.pairs.hist, sim.pairs.rhist, sim.pairs.touch, s.pos, ve, we, s.vel, s.omega, pred,
                              s.radius, s.mass, s.inertia, s._props, s.awake, s.active, sim.geom, sim.periodic, dt,
                              sim.wake_velocity, sim.force, sim.torque) + wake + (lo, hi, sim._law))
        ph["plane forces"] = (contacts.plane_forces,
                              (idx, pl.point, pl.normal, pl.velocity, pl.props, pl.hist, pl.rhist, s.pos, ve, we,
                               s.radius, s.mass, s.inertia, s._props, dt, sim.force, sim.torque, pl.reaction, lo, hi,
                               s.vel, s.omega, sim._law))
        ph["gravity"] = (forces._add_gravity, (idx, s.mass, sim.gravity.g, sim.force))
        ph["global damping"] = (forces.add_global_damping, (idx, ve, we, s.c_gn, s.c_gw, 1.0, sim.force, sim.torque))
        ph["kick (2nd)"] = ph["kick"]
        # the compiled loop's fused passes (steploop.first_pass / second_pass): what it runs instead of the above
        fp_args = (idx, s.pos, s.vel, s.omega, sim.force, sim.torque, w["fp"], w["tp"], w["v"], w["w"], sim._inv_m,
                   sim._inv_i, sim.lmask, sim.rmask, h, dt, pred, float(it.extrapolate), sim.geom, sim.periodic,
                   sim._box, sim._use_box, s.active.copy(), s.awake.copy(), sim._tmp_ids, sim.pairs.pos_build)
        ph["first_pass (fused)"] = (steploop.first_pass, fp_args)
        if hasattr(steploop, "any_damping"):
            damp = bool(steploop.any_damping(idx, s.c_gn, s.c_gw))
            ph["second_pass (fused)"] = (steploop.second_pass,
                                         (idx, s.active, True, s.mass, sim.gravity.g, ve, we, s.c_gn, s.c_gw, damp,
                                          sim.force, sim.torque, s.vel, s.omega, sim._inv_m, sim._inv_i, h, sim.lmask,
                                          sim.rmask))
        else:
            ph["second_pass (fused)"] = (steploop.second_pass,
                                         (idx, s.active, True, s.mass, sim.gravity.g, ve, we, s.c_gn, s.c_gw,
                                          sim.force, sim.torque, s.vel, s.omega, sim._inv_m, sim._inv_i, h, sim.lmask,
                                          sim.rmask))
        ph["sleep/step stats"] = (steploop.step_event,
                                  (1, 0.0, 0.0, 0, 0, -1.0, 0, 0, 1, np.zeros(5), False, np.zeros(1, np.int64), idx,
                                   s.vel, s.omega, s.vel_prev, s.omega_prev, s.radius, 0.0, 1, sim.sleepers.count,
                                   s.awake, sim._tmp_ids, 0, 1))
        best = {}
        hist_arg = {"pair forces": 2, "plane forces": 5}  # the contact histories: reset before each call
        for name, (fn, args) in ph.items():
            _repeat(1, fn, _writable(args))  # compile
            b = math.inf
            for _ in range(a.reps):
                wargs = _writable(args)
                k = hist_arg.get(name)
                b = min(b, _timed(a.calls, fn, wargs, None if k is None else (wargs[k], args[k].copy())))
            best[name] = b / n * 1e9
        c = time.process_time()
        for _ in range(3):
            sim.pairs.rebuild()
        reb = (time.process_time() - c) / 3 / n * 1e9
        print(f"{a.scene}, N = {n}, {integ}, {law}: {sim.pairs.pa.size} listed pairs, {sim.n_contacts} contacts")
        for name, ns in best.items():
            print(f"  {name:24s} {ns:7.1f} ns per particle")
        fused = ("first_pass (fused)", "second_pass (fused)", "pair forces", "plane forces", "sleep/step stats")
        tot = sum(v for k, v in best.items() if k in fused)
        print(f"  {'sum, compiled loop':24s} {tot:7.1f}  (pair, plane, fused first and second pass, stats)\n"
              f"  {'whole step (sim.step)':24s} {whole:7.1f}  "
              f"(one rebuild: {reb:.0f} ns per particle)")
    return 0


def main(argv) -> int:
    ap = argparse.ArgumentParser(prog="bench dem_kernel", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--calls", type=int, default=2000)
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--phases", action="store_true", help="cost of each pass of a compiled Verlet step")
    ap.add_argument("--scene", default="bed", choices=("bed", "pour"))
    ap.add_argument("--old", help="src directory of another tree: its pair and plane kernels timed interleaved")
    ap.add_argument("--steps", type=int, default=300, help="--phases, --steps-ab: steps timed for the whole step")
    ap.add_argument("--steps-ab", action="store_true", help="whole steps of this tree and --old's, three modes")
    ap.add_argument("--compile", action="store_true",
                    help="CPU seconds to compile the pair kernel on an empty numba cache (and --old's)")
    a = ap.parse_args(argv)
    if a.phases:
        return phases(a)
    if a.compile:
        return compile_cost(a)
    if a.steps_ab:
        return steps_ab(a)
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/, for the published benchmarks' helpers
    import bench_dem

    from breachflow.dem import pair_contacts as contacts

    mods = {"": contacts}
    if a.old:
        mods["old "] = _old_contacts(a.old)
    sim, _ = bench_dem.settled_bed(a.n) if a.scene == "bed" else bench_dem.poured_pile(a.n)
    sim.step(5)
    s = sim.state
    f, t = sim.force.copy(), sim.torque.copy()
    dt = sim.dt
    vp, wp = s.vel + 1e-4, s.omega + 1e-4  # predicted velocities (predicted_verlet: split)

    def pair_args(ve, we, split, law_code):
        return (sim.pairs.pa, sim.pairs.pb, sim.pairs.hist.copy(), sim.pairs.rhist.copy(), sim.pairs.touch.copy(), s.pos, ve, we, s.vel,
                s.omega, split, s.radius, s.mass, s.inertia, s._props, s.awake, s.active, sim.geom, sim.periodic, dt,
                sim.wake_velocity, f, t, sim.sleepers.wake_flag, sim.sleepers.wake_ids, np.zeros(1, np.int64),
                *((-0.5 * dt, 0.5 * dt) if law_code == 0 else (0.0, 0.0)), law_code)

    pl = sim.boundaries[0]

    def plane_args(law_code):
        return (sim.idx, pl.point, pl.normal, pl.velocity, pl.props, pl.hist.copy(), pl.rhist.copy(), s.pos, s.vel,
                s.omega, s.radius, s.mass, s.inertia, s._props, dt, f, t, pl.reaction.copy(),
                *((-0.5 * dt, 0.5 * dt) if law_code == 0 else (0.0, 0.0)), s.vel, s.omega, law_code)

    kernels = {}
    for tag, mod in mods.items():  # (kernel, arguments, the position of its history array in them)
        kernels[tag + "interval, predicted"] = (mod.pair_forces_interval, pair_args(vp, wp, True, 0), 2)
        kernels[tag + "interval, velocity"] = (mod.pair_forces_interval, pair_args(s.vel, s.omega, False, 0), 2)
        kernels[tag + "hooke_history"] = (mod.pair_forces_interval, pair_args(s.vel, s.omega, False, 1), 2)
        kernels[tag + "plane, interval"] = (mod.plane_forces, plane_args(0), 5)
        kernels[tag + "plane, hooke"] = (mod.plane_forces, plane_args(1), 5)
    if hasattr(contacts, "uniform_awake"):  # the pair kernel's per-call test for its one-material fast path
        kernels["uniform_awake scan"] = (contacts.uniform_awake, (s._props, s.awake, s.active), None)
    kernels["bare Hooke"] = (bare_hooke, (sim.pairs.pa, sim.pairs.pb, s.pos, s.radius, float(s.kn[0]), sim.geom, sim.periodic,
                                          f), None)
    times = {k: [] for k in kernels}
    resets = {name: None if k is None else (args[k], args[k].copy()) for name, (fn, args, k) in kernels.items()}
    for fn, args, _ in kernels.values():
        _repeat(1, fn, args)
    for rep in range(a.reps):
        order = list(kernels.items())
        for name, (fn, args, _) in (order if rep % 2 == 0 else order[::-1]):  # alternate: no order bias
            times[name].append(_timed(a.calls, fn, args, resets[name]))
    npairs, ntouch = sim.pairs.pa.size, int(bare_hooke(*kernels["bare Hooke"][1]))
    print(f"{a.scene}, {a.n} spheres: {npairs} listed pairs, {ntouch} in contact; CPU ns per listed pair "
          f"(planes, scan: per particle), best and median of {a.reps}")
    for name, sec in times.items():
        per = s.n if "plane" in name or "scan" in name else npairs
        print(f"{name:26s} {min(sec) / per * 1e9:6.1f}  {st.median(sec) / per * 1e9:6.1f}")
    if a.old:
        for name in [k for k in kernels if not k.startswith("old ") and "old " + k in kernels]:
            r = [o / n for o, n in zip(times["old " + name], times[name])]
            print(f"old/new {name:18s} best {min(times['old ' + name]) / min(times[name]):.3f}, paired "
                  f"{st.mean(r):.3f} ± {st.stdev(r) if len(r) > 1 else float('nan'):.3f}")
    return 0


_STEPS = """
import json, sys, time
import numpy as np
sys.path.insert(0, {bench!r})
import bench_dem as b
d = np.load({f!r})
sim = b.make_sim(d["pos"], d["vel"], float(d["L"]), {integ!r}, omega=d["om"], law={law!r})
sim.step(20)
c = time.process_time(); sim.step({steps}); cpu = time.process_time() - c
print(json.dumps(sim.state.n * {steps} / cpu))
"""


def steps_ab(a) -> int:
    """Whole-step A/B of this tree against --old's (module docstring)."""
    import os
    import subprocess
    import tempfile

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/, for the published benchmarks' helpers
    import bench_dem

    tmp = Path(tempfile.mkdtemp())
    sim, L = bench_dem.settled_bed(a.n) if a.scene == "bed" else bench_dem.poured_pile(a.n)
    np.savez(tmp / "s.npz", pos=sim.state.pos, vel=sim.state.vel, om=sim.state.omega, L=L)
    trees = {"old": Path(a.old).resolve(), "new": Path(__file__).resolve().parents[2] / "src"}
    modes = (("velocity_verlet", "step_averaged"), ("predicted_verlet", "step_averaged"),
             ("velocity_verlet", "hooke_history"))
    rates = {}
    for _ in range(a.reps):
        for integ, law in modes:
            for tag, src in trees.items():
                code = _STEPS.format(bench=str(Path(__file__).resolve().parents[1]), f=str(tmp / "s.npz"), integ=integ,
                                     law=law, steps=a.steps)
                env = dict(os.environ, PYTHONPATH=str(src), NUMBA_CACHE_DIR=str(tmp / ("c_" + tag)))
                out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
                rates.setdefault((integ, law, tag), []).append(float(out.stdout.strip().splitlines()[-1]))
    sd = lambda v: st.stdev(v) if len(v) > 1 else float("nan")  # noqa: E731
    print(f"{a.scene}, {sim.state.n} spheres, {a.steps} steps, M particle-steps per CPU s (mean ± sd of {a.reps})")
    for integ, law in modes:
        o, n = rates[(integ, law, "old")], rates[(integ, law, "new")]
        r = [y / x for x, y in zip(o, n)]
        print(f"  {integ:17s} {law:16s} old {st.mean(o) / 1e6:.2f} ± {sd(o) / 1e6:.2f}  new {st.mean(n) / 1e6:.2f} ± "
              f"{sd(n) / 1e6:.2f}; new/old {st.mean(r):.3f} ± {sd(r):.3f}")
    return 0


_COMPILE = """
import time, numpy as np
c = time.process_time()
from breachflow.dem import pair_contacts as contacts
c1 = time.process_time()
n = 3
pos = np.array([[0.0, 0, 0], [0, 0, 0.99], [0, 0, 1.98]]); z = np.zeros((n, 3)); props = np.tile([0.0, 0.5, 1e7, 1e7, 1e3, 1e3, 1e3, 0.0], (n, 1))
contacts.pair_forces_interval(np.array([0, 1]), np.array([1, 2]), np.zeros((2, 3)), np.zeros((2, 3)), np.zeros(2, bool), pos, z, z,
    z, z, False, np.full(n, 0.5), np.ones(n), np.ones(n), props, np.ones(n, bool), np.ones(n, bool), np.zeros(8),
    np.zeros(2, np.int64), 1e-3, 0.1, np.zeros((n, 3)), np.zeros((n, 3)), np.zeros(n, bool), np.zeros(n, np.int64),
    np.zeros(1, np.int64), -5e-4, 5e-4, 0)
print(contacts.__file__, f"{time.process_time() - c1:.1f}")
"""


def compile_cost(a) -> int:
    """First call of ``contacts.pair_forces_interval`` in a fresh process with an empty numba cache (CPU s),
    for this tree and --old's (its whole ``breachflow`` package put first on PYTHONPATH)."""
    import os
    import subprocess
    import tempfile

    trees = {"new": None} | ({"old": a.old} if a.old else {})
    for tag, src in trees.items():
        with tempfile.TemporaryDirectory() as cache:
            env = dict(os.environ, NUMBA_CACHE_DIR=cache)
            if src:
                env["PYTHONPATH"] = str(Path(src).resolve())
            out = subprocess.run([sys.executable, "-c", _COMPILE], env=env, capture_output=True, text=True, check=True)
            path, sec = out.stdout.split()
            print(f"{tag}: pair_forces_interval compiled in {sec} CPU s on an empty cache ({path})")
    return 0


def _old_contacts(src):
    """dem/pair_contacts.py (dem/contacts.py in older trees) of another source tree (*src*: its ``src``
    directory), imported under another name: the tree's whole ``breachflow`` package is copied as
    ``old_breachflow``, so that its relative imports (``.contact_law``, ``..registry``, ...) find the old
    modules beside it."""
    import importlib
    import shutil
    import tempfile

    tmp = Path(tempfile.mkdtemp())
    shutil.copytree(Path(src) / "breachflow", tmp / "old_breachflow", ignore=shutil.ignore_patterns("__pycache__"))
    sys.path.insert(0, str(tmp))
    dem = tmp / "old_breachflow" / "dem"
    name = "pair_contacts" if (dem / "pair_contacts.py").exists() else "contacts"
    return importlib.import_module(f"old_breachflow.dem.{name}")


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
