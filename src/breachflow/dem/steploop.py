"""Many DEM steps inside one compiled call (issue 16): the pieces of the step loop and the driver's side.

The loop itself is :func:`breachflow.coupling.steploop.fluid_verlet_steps`, one loop for the dry scenes of this module
(spheres, fixed planes, gravity, global damping: :func:`eligible`, :func:`run`) and for the closure cycle's
scene (a height field and fluid forces). It runs the steps of the two Verlet integrators
(``velocity_verlet``, ``predicted_verlet``, :mod:`.integrators`) with the same kernels in the same order as
the step-by-step path of ``DemSimulation._one_step``, so the results are bit-identical
(tests/dem/test_steploop.py, test_steploop_fluid.py), without a Python round trip per step. When a step's
drift needs a neighbour-list rebuild (some awake particle moved more than ``skin/2`` since the last build, as
LAMMPS' ``neigh_modify check yes``, decided after the drift, before the forces) it rebuilds inside the call
with :func:`.neighbours.rebuild`, the
driver's rebuild between events (``PairList.relist``), so the list — awake particles with each other
and with sleeping ones, histories carried over — is the same on both paths, with or without sleepers. It
stops after a step with an event the driver handles in Python: a particle left the domain, a sleeping
particle was touched by a moving one, particles fell asleep, the equilibrium criterion was met, or a
non-finite position (the driver raises). The sleeping grid is rebuilt (and histories parked or restored)
only at these events (:func:`current_list`), so between two of them the DEM of the closure cycle, with its
resting masses asleep, runs in one compiled call. On dry scenes without sleeping, a step that ends no call
(not the last, no leaver, not converged: decided before its closing kick) is closed and the next one
opened in one pass over the particles (:func:`close_and_first_pass`; otherwise :func:`second_pass` then
:func:`first_pass`), with the same roundings in the same order.
"""
from __future__ import annotations

import math
from typing import Protocol

import numba
import numpy as np

from ..registry import Registry
from .pair_contacts import sleep_update
from .neighbours import displacement_since
from .periodic import min_image, outside, wrapped

#: why the compiled loop (:func:`breachflow.coupling.steploop.fluid_verlet_steps`) returned
DONE, LEFT, BAD, WAKE, SLEEP, CONVERGED = range(6)


@numba.njit(cache=True)
def still_active(idx, active):
    """The entries of *idx* whose particles are still active (those that left the domain were retired)."""
    keep = 0
    for k in range(idx.shape[0]):
        if active[idx[k]]:
            keep += 1
    out = np.empty(keep, np.int64)
    keep = 0
    for k in range(idx.shape[0]):
        if active[idx[k]]:
            out[keep] = idx[k]
            keep += 1
    return out


@numba.njit(cache=True, error_model="numpy")
def first_pass(idx, pos, vel, omega, force, torque, fp, tp, vp, wp, inv_m, inv_i, lmask, rmask, h, dt, predict,
               extrapolate, geom, periodic, box, use_box, active, awake, left_ids, pos_build):
    """A Verlet step up to its force evaluation in one pass over the particles: kick
    (:func:`.integrators.kick`), drift (:func:`.integrators.drift`), wrap / retire leavers
    (:func:`.neighbours.wrap_and_check`), predict (:func:`.integrators.predict_extrapolated`), zero the force and
    torque rows of those still active (each particle's operations in the order of those passes, so
    bit-identical to them), and the displacement since the last list build (after
    the drift: this step's rebuild check, as :func:`.neighbours.displacement_since`). Returns
    (bad id or -1, #left, idx, the kicked idx, ve, we, max and sum step displacement, max displacement
    since the build, the largest predicted speed ``|vp|`` of the active particles if *predict*, else 0: the
    plane lists' check, :func:`.wall_contacts.candidates_hold`). :func:`close_and_first_pass` without its closing
    part.

    Each particle's rows are loaded once into scalars and stored once (numba cannot tell that the arrays do
    not overlap, so it reloads a row after every store), and the rows are indexed with an unsigned index
    (no wraparound test for negative indices on each access): the pass costs about 0.75x the row-by-row
    form on the 1000-sphere settled bed (``python3 tasks.py bench dem_kernel --phases``, docs/performance.md)."""
    return close_and_first_pass(idx, pos, vel, omega, force, torque, fp, tp, vp, wp, inv_m, inv_i, lmask, rmask, h,
                                dt, predict, extrapolate, geom, periodic, box, use_box, active, awake, left_ids,
                                pos_build, False, False, inv_m, lmask, inv_m, inv_m, False)


@numba.njit(cache=True, error_model="numpy")
def close_and_first_pass(idx, pos, vel, omega, force, torque, fp, tp, vp, wp, inv_m, inv_i, lmask, rmask, h, dt,
                         predict, extrapolate, geom, periodic, box, use_box, active, awake, left_ids, pos_build,
                         close, gravity, mass, g, c_gn, c_gw, damp):
    """If *close*: the end of a Verlet step (:func:`second_pass` over *idx*: gravity if *gravity*, global
    damping if *damp* on the velocities of the force evaluation — ``vp``/``wp`` if *predict*, else
    ``vel``/``omega`` —, the closing kick) fused with the next step's :func:`first_pass` in one pass, so each
    particle's rows are loaded and stored once per step; per particle the operations of the two passes in
    their order (two half kicks ``v += h a``, two roundings), so bit-identical to them. The force and torque
    rows of a particle retired or non-finite in the first part keep the closing pass's sums, as after
    :func:`second_pass`. Only where the closing pass's particles are the first pass's (no leaver in the
    closing step) and no event ends the call after it (:func:`breachflow.coupling.steploop.fluid_verlet_steps`).
    Returns as :func:`first_pass`."""
    mx = 0.0
    sm = 0.0
    m2 = 0.0
    vp2 = 0.0
    nleft = 0
    bad = -1
    c = extrapolate
    Lx = geom[6]
    Ly = geom[7]
    px = periodic[0]
    py = periodic[1]
    l0, l1, l2 = lmask[0], lmask[1], lmask[2]
    r0, r1, r2 = rmask[0], rmask[1], rmask[2]
    g0, g1, g2 = g[0], g[1], g[2]
    for k in range(idx.shape[0]):
        i = np.uint64(idx[k])
        im = inv_m[i]
        ii = inv_i[i]
        a = active[i]
        f0, f1, f2 = force[i, 0], force[i, 1], force[i, 2]
        t0, t1, t2 = torque[i, 0], torque[i, 1], torque[i, 2]
        v0, v1, v2 = vel[i, 0], vel[i, 1], vel[i, 2]
        w0, w1, w2 = omega[i, 0], omega[i, 1], omega[i, 2]
        if close:  # second_pass
            if a:
                if gravity:
                    m = mass[i]
                    f0 += m * g0
                    f1 += m * g1
                    f2 += m * g2
                if damp:
                    cn = c_gn[i]
                    cw = c_gw[i]
                    if predict:
                        f0 -= 1.0 * cn * vp[i, 0]
                        f1 -= 1.0 * cn * vp[i, 1]
                        f2 -= 1.0 * cn * vp[i, 2]
                        t0 -= 1.0 * cw * wp[i, 0]
                        t1 -= 1.0 * cw * wp[i, 1]
                        t2 -= 1.0 * cw * wp[i, 2]
                    else:
                        f0 -= 1.0 * cn * v0
                        f1 -= 1.0 * cn * v1
                        f2 -= 1.0 * cn * v2
                        t0 -= 1.0 * cw * w0
                        t1 -= 1.0 * cw * w1
                        t2 -= 1.0 * cw * w2
            v0 = v0 + h * f0 * im * l0  # closing kick
            v1 = v1 + h * f1 * im * l1
            v2 = v2 + h * f2 * im * l2
            w0 = w0 + h * t0 * ii * r0
            w1 = w1 + h * t1 * ii * r1
            w2 = w2 + h * t2 * ii * r2
        v0 = v0 + h * f0 * im * l0  # kick
        v1 = v1 + h * f1 * im * l1
        v2 = v2 + h * f2 * im * l2
        w0 = w0 + h * t0 * ii * r0
        w1 = w1 + h * t1 * ii * r1
        w2 = w2 + h * t2 * ii * r2
        x0 = pos[i, 0] + v0 * dt  # drift
        x1 = pos[i, 1] + v1 * dt
        x2 = pos[i, 2] + v2 * dt
        s = 0.0
        s += v0 * v0
        s += v1 * v1
        s += v2 * v2
        s = np.sqrt(s) * dt
        sm += s
        if s > mx:
            mx = s
        if not (math.isfinite(x0) and math.isfinite(x1) and math.isfinite(x2)
                and math.isfinite(v0) and math.isfinite(v1) and math.isfinite(v2)):
            vel[i, 0], vel[i, 1], vel[i, 2] = v0, v1, v2
            omega[i, 0], omega[i, 1], omega[i, 2] = w0, w1, w2
            pos[i, 0], pos[i, 1], pos[i, 2] = x0, x1, x2
            if close:
                force[i, 0], force[i, 1], force[i, 2] = f0, f1, f2
                torque[i, 0], torque[i, 1], torque[i, 2] = t0, t1, t2
            if bad < 0:
                bad = idx[k]
            continue
        if px:  # as .neighbours.wrap_and_check
            x0 = wrapped(x0, geom[0], Lx)
        if py:
            x1 = wrapped(x1, geom[1], Ly)
        pos[i, 0], pos[i, 1], pos[i, 2] = x0, x1, x2
        if use_box and outside(x0, x1, x2, box, px, py):
            active[i] = False
            awake[i] = False
            a = False
            v0 = v1 = v2 = w0 = w1 = w2 = 0.0
            left_ids[nleft] = idx[k]
            nleft += 1
        vel[i, 0], vel[i, 1], vel[i, 2] = v0, v1, v2
        omega[i, 0], omega[i, 1], omega[i, 2] = w0, w1, w2
        if predict:
            e0, e1, e2 = fp[i, 0], fp[i, 1], fp[i, 2]
            q0, q1, q2 = tp[i, 0], tp[i, 1], tp[i, 2]
            a0 = v0 + h * (f0 + c * (f0 - e0)) * im * l0
            a1 = v1 + h * (f1 + c * (f1 - e1)) * im * l1
            a2 = v2 + h * (f2 + c * (f2 - e2)) * im * l2
            vp[i, 0], vp[i, 1], vp[i, 2] = a0, a1, a2
            a0 = a0 * a0 + a1 * a1 + a2 * a2
            if a and a0 > vp2:
                vp2 = a0
            wp[i, 0] = w0 + h * (t0 + c * (t0 - q0)) * ii * r0
            wp[i, 1] = w1 + h * (t1 + c * (t1 - q1)) * ii * r1
            wp[i, 2] = w2 + h * (t2 + c * (t2 - q2)) * ii * r2
            fp[i, 0], fp[i, 1], fp[i, 2] = f0, f1, f2
            tp[i, 0], tp[i, 1], tp[i, 2] = t0, t1, t2
        if a:
            force[i, 0] = force[i, 1] = force[i, 2] = 0.0
            torque[i, 0] = torque[i, 1] = torque[i, 2] = 0.0
            dx = min_image(x0 - pos_build[i, 0], Lx, px)
            dy = min_image(x1 - pos_build[i, 1], Ly, py)
            dz = x2 - pos_build[i, 2]
            d2 = dx * dx + dy * dy + dz * dz
            if d2 > m2:
                m2 = d2
        elif close:
            force[i, 0], force[i, 1], force[i, 2] = f0, f1, f2
            torque[i, 0], torque[i, 1], torque[i, 2] = t0, t1, t2
    kicked = idx
    if bad >= 0:
        return bad, nleft, idx, kicked, vel, omega, mx, sm, 0.0, 0.0
    if nleft:
        idx = still_active(idx, active)
    if predict:
        return bad, nleft, idx, kicked, vp, wp, mx, sm, math.sqrt(m2), math.sqrt(vp2)
    return bad, nleft, idx, kicked, vel, omega, mx, sm, math.sqrt(m2), 0.0


@numba.njit(cache=True, error_model="numpy")
def any_damping(idx, c_gn, c_gw):
    """Whether some particle of *idx* has a global damping coefficient (``c_gn`` or ``c_gw``) other than 0."""
    for k in range(idx.shape[0]):
        i = idx[k]
        if c_gn[i] != 0.0 or c_gw[i] != 0.0:
            return True
    return False


@numba.njit(cache=True, error_model="numpy")
def second_pass(kicked, active, gravity, mass, g, ve, we, c_gn, c_gw, damp, force, torque, vel, omega, inv_m, inv_i, h,
                lmask, rmask):
    """The end of a Verlet step in one pass: gravity (if *gravity*, as :class:`.forces.Gravity`) and, if
    *damp* (:func:`any_damping`), the global damping (:func:`.forces.add_global_damping`, scale 1) on the
    particles still active, then the closing kick (:func:`.integrators.kick`) of all *kicked* ones; per
    particle in that order, so bit-identical to the three passes. Without *damp* every coefficient is 0 and
    the damping would subtract ``0 * v`` (a zero) from force and torque sums that are never -0 (sums of
    products started from +0): nothing, for finite velocities; skipping it saves 4 ns per particle-step
    on the 1000-sphere settled bed (``python3 tasks.py bench dem_kernel --phases``). Rows are loaded once
    into scalars and indexed unsigned, as in :func:`first_pass`."""
    g0, g1, g2 = g[0], g[1], g[2]
    l0, l1, l2 = lmask[0], lmask[1], lmask[2]
    r0, r1, r2 = rmask[0], rmask[1], rmask[2]
    for k in range(kicked.shape[0]):
        i = np.uint64(kicked[k])
        f0, f1, f2 = force[i, 0], force[i, 1], force[i, 2]
        t0, t1, t2 = torque[i, 0], torque[i, 1], torque[i, 2]
        if active[i]:
            if gravity:
                m = mass[i]
                f0 += m * g0
                f1 += m * g1
                f2 += m * g2
            if damp:
                cn = c_gn[i]
                cw = c_gw[i]
                f0 -= 1.0 * cn * ve[i, 0]
                f1 -= 1.0 * cn * ve[i, 1]
                f2 -= 1.0 * cn * ve[i, 2]
                t0 -= 1.0 * cw * we[i, 0]
                t1 -= 1.0 * cw * we[i, 1]
                t2 -= 1.0 * cw * we[i, 2]
            force[i, 0], force[i, 1], force[i, 2] = f0, f1, f2
            torque[i, 0], torque[i, 1], torque[i, 2] = t0, t1, t2
        im = inv_m[i]
        ii = inv_i[i]
        vel[i, 0] += h * f0 * im * l0
        vel[i, 1] += h * f1 * im * l1
        vel[i, 2] += h * f2 * im * l2
        omega[i, 0] += h * t0 * ii * r0
        omega[i, 1] += h * t1 * ii * r1
        omega[i, 2] += h * t2 * ii * r2


@numba.njit(cache=True, error_model="numpy")
def next_ok(mx, sm, e_tol, crit, ok):
    """The count of consecutive steps below *e_tol* after a step of (max, sum) displacement *mx*, *sm*."""
    return ok + 1 if (mx if crit == 0 else sm) < e_tol else 0


@numba.njit(cache=True, error_model="numpy")
def step_event(done, mx, sm, nc, nleft, e_tol, crit, ok, consecutive, stats, sleeping, n_wake, idx, vel, omega,
               vel_prev, omega_prev, radius, v_sleep, n_sleep, sleep_count, awake, sleep_ids, step0, sleep_check):
    """After a finished step: record *stats*, count steps below *e_tol*, and return (the event that ends the
    compiled call — LEFT, WAKE, SLEEP, CONVERGED — or -1 to go on, updated ok)."""
    stats[0] = mx
    stats[1] = sm
    stats[2] = nc
    if e_tol >= 0.0:
        ok = next_ok(mx, sm, e_tol, crit, ok)
        stats[4] = ok
    if nleft:
        stats[3] = nleft
        return LEFT, ok
    if sleeping:
        if n_wake[0] > 0:
            stats[3] = n_wake[0]
            return WAKE, ok
        ns = sleep_update(idx, vel, omega, vel_prev, omega_prev, radius, v_sleep, n_sleep, sleep_count, awake,
                          sleep_ids, (step0 + done) % sleep_check == 0)
        if ns:
            stats[3] = ns
            return SLEEP, ok
    if e_tol >= 0.0 and ok >= consecutive:
        return CONVERGED, ok
    return -1, ok


def eligible(sim) -> bool:
    """Whether :func:`run` can advance *sim*: a fixed-step Verlet integrator, fixed planes only, no force
    models, awake particles and known forces (otherwise the driver steps in Python)."""
    from .boundaries import Plane
    from .integrators import VelocityVerlet

    integ = sim.integrator
    return (not sim.models and sim.idx.size > 0 and not sim.forces_stale
            and isinstance(integ, VelocityVerlet) and type(integ).step is VelocityVerlet.step
            and all(type(b) is Plane and b.control == "fixed" for b in sim.boundaries))


class StepLoop(Protocol):
    """A compiled many-steps loop (registry ``breachflow.step_loops``): :func:`eligible` says which
    simulations it can advance, :func:`run` advances one by up to ``nmax`` steps in one call."""

    def eligible(self, sim) -> bool: ...

    def run(self, sim, nmax: int, e_tol: float = -1.0, crit: int = 0, consecutive: int = 1, ok: int = 0): ...


#: The compiled step loops, by name. The built-in ``fluid_verlet``
#: (:mod:`breachflow.coupling.steploop`: the DEM step with the fluid forces inside it) lives above the DEM
#: and is found through its entry point, as a third-party loop would be.
step_loops: Registry[StepLoop] = Registry("compiled step loop", "breachflow.step_loops")
#: the loop that runs the dry scenes of this module (:func:`run`)
DRY_LOOP = "fluid_verlet"


def runner(sim):
    """The compiled many-steps runner that can advance *sim* (this module's :func:`run`, or the ``run`` of
    the first loop in :data:`step_loops` whose ``eligible(sim)`` holds: height fields and fluid forces), or
    None (step in Python)."""
    if eligible(sim):
        return run
    for name in step_loops.available():
        loop = step_loops.get(name)
        if loop.eligible(sim):
            return loop.run
    return None


def run(sim, nmax: int, e_tol: float = -1.0, crit: int = 0, consecutive: int = 1, ok: int = 0):
    """Advance *sim* (:func:`eligible`) by up to *nmax* steps in one compiled call: the cycle's loop
    (:func:`breachflow.coupling.steploop.run`, :data:`DRY_LOOP`) without height field and fluid forces;
    returns (steps done, last (max, sum) displacement, ok)."""
    return step_loops.get(DRY_LOOP).run(sim, nmax, e_tol, crit, consecutive, ok)


def current_list(sim):
    """Before a compiled call: rebuild the pair list now when it is out of date (``PairList.dirty``,
    or some awake particle moved more than ``skin/2``) or the sleeping grid is (an event since it was built:
    the rebuild parks or restores histories), so that the rebuilds inside the call are the driver's
    between events (``PairList.relist``)."""
    pl = sim.pairs
    if pl.sgrid is None:
        pl.sleep_grid_dirty = True
    if (pl.dirty or pl.sleep_grid_dirty
            or displacement_since(sim.idx, sim.state.pos, pl.pos_build, sim.geom, sim.periodic) > 0.5 * sim.skin):
        pl.rebuild()


def relist_args(sim):
    """The rebuild arguments of the compiled loop: cells per period, one cell per particle or not, the
    sleeping grid and the pair buffers."""
    from .neighbours import empty_buffers

    bufs = sim.pairs.bufs or empty_buffers()
    return sim.ncell, bool(sim.single_bin), sim.pairs.sgrid, bufs


def finish(sim, planes, pl_hist, pl_rhist, reaction, done, why, t, stats, n0, e_tol, ok):
    """The driver's bookkeeping after a compiled many-steps call (this module's or
    :mod:`breachflow.coupling.steploop`'s) that ended with reason *why*; returns (steps done, last (max, sum)
    displacement, ok)."""
    from ..errors import PhysicsError

    s = sim.state
    dt = sim._dt
    for k, b in enumerate(planes):
        b.hist[:] = pl_hist[k]
        b.rhist[:] = pl_rhist[k]
        if done:
            b.reaction[:] = reaction[k]
    if why == BAD:
        raise PhysicsError(
            f"particle {int(stats[3])} has a non-finite position/velocity at t={t:.6g} s; the time step "
            f"{dt:.3g} s (stable limit {sim.dt_limit:.3g} s) or the inputs are unstable")
    sim.t = t
    sim.steps += done
    if done:
        sim.n_contacts = int(stats[2])
    if e_tol >= 0.0 and done:
        ok = int(stats[4])
    if why == LEFT:
        nleft = int(stats[3])
        sim.left_domain.extend(int(i) for i in sim._tmp_ids[:nleft])
        sim.idx = sim.idx[s.active[sim.idx]]
        sim.pairs.invalidate()
        sim.particle_steps += (done - 1) * n0 + sim.idx.size
    else:
        sim.particle_steps += done * n0
    if why in (LEFT, WAKE) and sim.sleeping:
        sim.sleepers.sleep_and_wake()
    elif why == SLEEP:
        sim.sleepers.after_sleep(int(stats[3]))
    return done, (float(stats[0]), float(stats[1])), ok
