"""Single impacts at a chosen contact-onset phase, for tests/dem/test_impact_phases.py (issue 12).

Every case starts in free flight (no gravity) with the gap closed at a constant speed, so the contact
begins at ``(3 + phase) dt`` exactly, and ends in free flight, so onset and release times follow from
the free-flight positions exactly. Expectations are analytic (docs/theory.md, *DEM contact*; Chung & Ooi 2011 test 4).

``python tests/dem/impact_cases.py [integrator]`` prints the tables quoted in docs/validation.md (DEM impacts).
"""
from __future__ import annotations

import math

import numpy as np

from breachflow.dem import DemSimulation, HeightField, Material, Plane, sphere_mass

R, RHO, K = 0.25, 2650.0, 2.0e7
M = float(sphere_mass(R, RHO))
PHASES = np.arange(8) / 8.0 + 0.03  # 8 onset phases (fractions of a step), none on a step boundary
SLOPE = 0.3  # terrain: plane z = SLOPE x sampled on a grid (bilinear = planar, so the normal is exact)


def linear_restitution(zeta: float) -> tuple[float, float]:
    """(e, contact duration * omega_0) of the linear spring–dashpot (docs/theory.md, *DEM contact*)."""
    return math.exp(-zeta * math.pi / math.sqrt(1 - zeta**2)), math.pi / math.sqrt(1 - zeta**2)


def _terrain(mat):
    x = np.arange(-20.0, 21.0)
    y = np.arange(-20.0, 21.0)
    return HeightField(x, y, SLOPE * x[None, :] * np.ones((y.size, 1)), mat)


def normal_impact(kind: str, zeta: float, phase: float, integrator="predicted_verlet", dt=None, speed=2.0):
    """Head-on impact, ``kind`` in plane / pair / terrain; returns relative errors (e, contact duration)
    and the steps per contact. ``dt`` None: the simulation's default step."""
    m_eff = M / 2 if kind == "pair" else M
    c = 2 * zeta * math.sqrt(K * m_eff)
    mat = Material(density=RHO, kn=K, ks=K, friction=0.5, c_cn=c)
    bnd = {"plane": [Plane((0, 0, 0), (0, 0, 1), mat)], "pair": [], "terrain": [_terrain(mat)]}[kind]
    sim = DemSimulation(gravity=(0, 0, 0), integrator=integrator, dt=dt, sleeping=False, boundaries=bnd)
    if kind == "pair":
        n = np.array([1.0, 0.0, 0.0])
        sim.add_particles([[0, 0, 0], [1, 0, 0]], R, mat, vel=[0.5 * speed * n, -0.5 * speed * n])
    else:
        n = np.array([-SLOPE, 0.0, 1.0]) if kind == "terrain" else np.array([0.0, 0.0, 1.0])
        n /= np.linalg.norm(n)
        sim.add_particles([[0, 0, 0]], R, mat, vel=[-speed * n])
    w = speed
    gap0 = w * (3 + phase) * sim.dt

    def gap():
        s = sim.state
        return (s.pos[1] - s.pos[0]) @ n - 2 * R if kind == "pair" else s.pos[0] @ n - R

    def closing():
        s = sim.state
        return -(s.vel[1] - s.vel[0]) @ n if kind == "pair" else -s.vel[0] @ n

    if kind == "pair":
        sim.state.pos[1] = (2 * R + gap0) * n
    else:
        sim.state.pos[0] = (R + gap0) * n
    omega0 = math.sqrt(K / m_eff)
    e_exact, tc_exact = linear_restitution(zeta)
    tc_exact /= omega0
    steps = 0
    while True:
        sim.step()
        steps += 1
        if gap() > 0 and closing() < 0 and steps > 3 + tc_exact / sim.dt:
            break
        if steps > 100 * (4 + tc_exact / sim.dt):
            raise RuntimeError("contact never ended")
    sim.step(2)
    v_out = -closing()
    t1 = sim.t - gap() / v_out  # free flight back to the release
    t0 = gap0 / w
    return (v_out / w - e_exact) / e_exact, (t1 - t0 - tc_exact) / tc_exact, tc_exact / sim.dt


MU_CO = 0.092  # Chung & Ooi (2011) test 4: aluminium oxide sphere on a flat wall, mu = 0.092, |v| = 3.9 m/s
V_CO = 3.9


def chung_ooi_4(theta_deg: float, phase: float, integrator="predicted_verlet", dt=None, zeta=0.0):
    """Oblique impact on a wall at incidence *theta* (from the normal), k_S = 2/7 k_N, no initial spin.

    Returns (e_t, omega', tan(rebound angle)) with e_t = v_t'/v_t of the centre, omega' the spin about
    the axis of the rolling direction (rad/s), rebound angle from the contact-point tangential velocity."""
    c = 2 * zeta * math.sqrt(K * M)
    mat = Material(density=RHO, kn=K, ks=2.0 / 7.0 * K, friction=MU_CO, c_cn=c)
    sim = DemSimulation(gravity=(0, 0, 0), integrator=integrator, dt=dt, sleeping=False,
                        boundaries=[Plane((0, 0, 0), (0, 0, 1), mat)])
    th = math.radians(theta_deg)
    vt, vn = V_CO * math.sin(th), V_CO * math.cos(th)
    sim.add_particles([[0, 0, 0]], R, mat, vel=[[vt, 0, -vn]])
    sim.state.pos[0, 2] = R + vn * (3 + phase) * sim.dt
    tc = math.pi * math.sqrt(M / K)
    for _ in range(int(10 * tc / sim.dt) + 10):
        sim.step()
        if sim.state.pos[0, 2] > R and sim.state.vel[0, 2] > 0:
            break
    sim.step(2)  # the release may lie inside the last force interval
    v, w = sim.state.vel[0], sim.state.omega[0]
    slip = v[0] - w[1] * R  # contact-point velocity (contact point at -R z)
    return v[0] / vt, w[1], slip / v[2]


def chung_ooi_4_limits(theta_deg: float, e_n: float = 1.0):
    """Analytic (e_t, omega', tan rebound) in the sticking limit (tan theta <= 3.5 mu, k_S/k_N = 2/7, so
    the tangential oscillator omega_t = sqrt(k_S (1/m + R^2/I)) equals omega_N and the slip velocity
    reverses: tangential impulse 2 m_t v_t with m_t = 2m/7) and in gross sliding (tan theta >=
    3.5 (1 + e_n) mu: Coulomb impulse mu (1 + e_n) m v_n)."""
    th = math.radians(theta_deg)
    vt, vn = V_CO * math.sin(th), V_CO * math.cos(th)
    if math.tan(th) <= 3.5 * MU_CO:
        J = 4.0 / 7.0 * M * vt
    elif math.tan(th) >= 3.5 * (1 + e_n) * MU_CO:
        J = MU_CO * (1 + e_n) * M * vn
    else:
        raise ValueError("partial slip: no closed form here")
    vt1 = vt - J / M
    w1 = R * J / (0.4 * M * R * R)
    return vt1 / vt, w1, (vt1 - w1 * R) / (e_n * vn)


def column_is_stable(zeta: float, fraction: float, integrator="predicted_verlet") -> bool:
    """A column of two spheres resting on a floor (k_S = 0.2 k_N, so the normal pair mode sets the limit),
    normal damping ratio *zeta* (pair), dt = *fraction* x the stable limit: at rest after 2 s?"""
    from breachflow.dem import stable_dt

    c = 2 * zeta * math.sqrt(K * M / 2)
    mat = Material(density=RHO, kn=K, ks=0.2 * K, friction=0.5, c_cn=c)
    lim = stable_dt([M], [K], [0.2 * K], [c])
    sim = DemSimulation(boundaries=[Plane((0, 0, 0), (0, 0, 1), mat)], sleeping=False, dt=fraction * lim,
                        integrator=integrator)
    sim.add_particles([[0, 0, R], [0, 0, 3 * R + 0.01]], R, mat)
    try:
        sim.run(2.0)
    except Exception:  # PhysicsError: non-finite state
        return False
    return bool(np.all(np.isfinite(sim.state.vel)) and np.max(np.abs(sim.state.vel)) < 1e-3)


def phase_averaged_error(kind: str, zeta: float, n_steps: int, integrator="predicted_verlet") -> float:
    """Mean |restitution error| over the 8 onset phases and 4 release phases: steps per contact
    ``n_steps + 1/8, + 3/8, + 5/8, + 7/8`` (an integer number would make onset and release errors cancel)."""
    m_eff = M / 2 if kind == "pair" else M
    tc = linear_restitution(zeta)[1] / math.sqrt(K / m_eff)
    errs = [normal_impact(kind, zeta, p, integrator, dt=tc / (n_steps + f))[0]
            for f in (0.125, 0.375, 0.625, 0.875) for p in PHASES]
    return float(np.mean(np.abs(errs)))


if __name__ == "__main__":
    import sys

    integ = sys.argv[1] if len(sys.argv) > 1 else "predicted_verlet"
    print(f"integrator {integ}; onset phases {', '.join(f'{p:.3f}' for p in PHASES)}")
    for kind in ("plane", "pair", "terrain"):
        for zeta in (0.0, 0.1, 0.3):
            r = np.array([normal_impact(kind, zeta, p, integ) for p in PHASES])
            print(f"{kind:8s} zeta {zeta:.1f} steps/contact {r[0, 2]:5.1f}: restitution error "
                  f"min {100 * r[:, 0].min():+6.2f} % max {100 * r[:, 0].max():+6.2f} %; duration error "
                  f"max |.| {100 * np.abs(r[:, 1]).max():.2f} %")
    for theta in (5, 10, 15, 45, 60, 75):
        ex = np.array(chung_ooi_4_limits(theta))
        r = np.array([chung_ooi_4(theta, p, integ) for p in PHASES])
        err = (r - ex) / np.abs(ex)
        print(f"Chung-Ooi 4 theta {theta:2d}: analytic e_t {ex[0]:.4f} w' {ex[1]:8.3f} tan(reb) {ex[2]:+.4f};"
              f" max |rel err| e_t {100 * np.abs(err[:, 0]).max():.2f} % w' {100 * np.abs(err[:, 1]).max():.2f} %"
              f" tan(reb) {100 * np.abs(err[:, 2]).max():.2f} %")
    for n_steps in (49.8, 50.6):
        zeta = 0.3
        tc = linear_restitution(zeta)[1] / math.sqrt(K / M)
        r = np.array([normal_impact("plane", zeta, p, integ, dt=tc / n_steps) for p in PHASES])
        print(f"plane zeta 0.3 at {n_steps} steps/contact: restitution error min {100 * r[:, 0].min():+.2f} %"
              f" max {100 * r[:, 0].max():+.2f} %")
    for zeta in (0.1, 0.3):
        line = []
        for n_steps in (10, 20, 40, 80):
            line.append(f"{n_steps}: {100 * phase_averaged_error('plane', zeta, n_steps, integ):.4f} %")
        print(f"plane zeta {zeta}: phase-averaged |restitution error| at ~steps/contact " + ", ".join(line))
    for zeta in (0.3, 0.7, 1.5):
        ok = [f for f in (0.2, 0.3, 0.4, 0.5, 0.6, 0.8, 0.95) if column_is_stable(zeta, f, integ)]
        print(f"column of two spheres, zeta {zeta}: at rest after 2 s at dt/limit = {ok}")

