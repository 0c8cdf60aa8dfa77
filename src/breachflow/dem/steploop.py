"""Many DEM steps inside one compiled call (issue 16).

:func:`verlet_steps` runs the steps of the two Verlet integrators (``velocity_verlet``,
``predicted_verlet``, :mod:`.integrators`) for a scene of spheres, fixed planes, gravity and global damping
(no force models) in one numba loop: the same kernels in the same order as the step-by-step path of
``DemSimulation._one_step``, so the results are bit-identical
(tests/dem/test_steploop.py), without a Python round trip per step. Before a step that needs a
neighbour-list rebuild (some awake particle moved more than ``skin/2`` since the last build, as LAMMPS'
``neigh_modify check yes``) it returns REBUILD; :func:`verlet_steps_relisting` then rebuilds inside the
compiled call with :func:`.neighbours.rebuild`, the driver's rebuild between events (``DemSimulation._relist``),
so the list — awake particles with each other and with sleeping ones, histories carried over — is the same
on both paths, with or without sleepers. It stops after a step with an event the driver handles in Python:
a particle left the domain, a sleeping particle was touched by a moving one, particles fell asleep, the
equilibrium criterion was met, or a non-finite position (the driver raises). The sleeping grid is rebuilt
(and histories parked or restored) only at these events, so between two of them the DEM of the closure
cycle, with its resting masses asleep, runs in one compiled call.
"""
from __future__ import annotations

import numba
import numpy as np

from .contacts import displacement_since, pair_forces_window, plane_forces, sleep_update, wrap_and_check
from .forces import _add_gravity, add_global_damping, zero_rows
from .integrators import drift, kick, predict_extrapolated
from .neighbours import rebuild

#: why :func:`verlet_steps` returned
DONE, REBUILD, LEFT, BAD, WAKE, SLEEP, CONVERGED = range(7)


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
def first_half(idx, pos, vel, omega, force, torque, fp, tp, vp, wp, inv_m, inv_i, lmask, rmask, h, dt, predict,
               extrapolate, geom, periodic, box, use_box, active, awake, left_ids):
    """A Verlet step up to its force evaluation: kick, drift, wrap / retire leavers, drop them from *idx*,
    predict. Returns (bad id or -1, #left, idx, the kicked idx, velocities for the forces (ve, we), max
    and sum displacement)."""
    kick(idx, vel, omega, force, torque, inv_m, inv_i, h, lmask, rmask)
    mx, sm = drift(idx, pos, vel, dt)
    kicked = idx  # the step's particles: retired ones still get the closing kick, as in the integrators
    nleft, bad = wrap_and_check(idx, pos, vel, omega, geom, periodic, box, use_box, active, awake, left_ids)
    if bad >= 0:
        return bad, nleft, idx, kicked, vel, omega, mx, sm
    if nleft:  # forces are computed without them (as after_drift)
        idx = still_active(idx, active)
    if predict:
        predict_extrapolated(kicked, vel, omega, force, torque, fp, tp, inv_m, inv_i, h, extrapolate, lmask,
                             rmask, vp, wp)
        return bad, nleft, idx, kicked, vp, wp, mx, sm
    return bad, nleft, idx, kicked, vel, omega, mx, sm


@numba.njit(cache=True, error_model="numpy")
def step_event(done, mx, sm, nc, nleft, e_tol, crit, ok, consecutive, stats, sleeping, n_wake, idx, vel, omega,
               vel_prev, omega_prev, radius, v_sleep, n_sleep, sleep_count, awake, sleep_ids, step0, sleep_check):
    """After a finished step: record *stats*, count steps below *e_tol*, and return (the event that ends the
    compiled call — LEFT, WAKE, SLEEP, CONVERGED — or -1 to go on, updated ok)."""
    stats[0] = mx
    stats[1] = sm
    stats[2] = nc
    if e_tol >= 0.0:
        ok = ok + 1 if (mx if crit == 0 else sm) < e_tol else 0
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


@numba.njit(cache=True, error_model="numpy")
def verlet_steps(nmax, t, idx, pos, vel, omega, vel_prev, omega_prev, force, torque, fp, tp, vp, wp, inv_m, inv_i,
                 lmask, rmask, dt, predict, extrapolate, lo, hi, pa, pb, hist, rhist, touch, radius, mass, inertia,
                 props, awake, active, geom, periodic, wake_speed, wake, wake_ids, n_wake, pl_point, pl_normal,
                 pl_vel, pl_props, pl_hist, pl_rhist, pl_reaction, g, c_gn, c_gw, box, use_box, left_ids, pos_build,
                 half_skin, sleeping, v_sleep, n_sleep, sleep_count, sleep_ids, sleep_check, step0, e_tol, crit,
                 consecutive, ok, stats, law=0):
    """Up to *nmax* Verlet steps (kick, drift, wrap, contacts, planes, gravity, damping, kick) of the awake
    particles *idx*; returns (steps done, reason, time). *stats* (out): [max, sum displacement of the last
    step, contacts, #left / #woken / #asleep / bad id, consecutive steps below *e_tol*]; ``e_tol < 0``: no
    equilibrium test. *crit* 0: max criterion, 1: sum. ``ok``: consecutive steps below e_tol so far. *law*: kernel
    code of the contact law (:mod:`.contact_laws`)."""
    h = 0.5 * dt
    done = 0
    for _ in range(nmax):
        if displacement_since(idx, pos, pos_build, geom, periodic) > half_skin:
            return done, REBUILD, t
        n_wake[0] = 0
        bad, nleft, idx, kicked, ve, we, mx, sm = first_half(idx, pos, vel, omega, force, torque, fp, tp, vp, wp,
                                                             inv_m, inv_i, lmask, rmask, h, dt, predict, extrapolate,
                                                             geom, periodic, box, use_box, active, awake, left_ids)
        if bad >= 0:
            stats[3] = bad
            return done, BAD, t
        zero_rows(idx, force, torque)
        nc = pair_forces_window(pa, pb, hist, rhist, touch, pos, ve, we, vel, omega, predict, radius, mass, inertia,
                                props, awake, active, geom, periodic, dt, wake_speed, force, torque, wake, wake_ids,
                                n_wake, lo, hi, law)
        for b in range(pl_point.shape[0]):
            pl_reaction[b, :] = 0.0
            nc += plane_forces(idx, pl_point[b], pl_normal[b], pl_vel[b], pl_props[b], pl_hist[b], pl_rhist[b], pos,
                               ve, we, radius, mass, inertia, props, dt, force, torque, pl_reaction[b], lo, hi, vel,
                               omega, law)
        _add_gravity(idx, mass, g, force)
        add_global_damping(idx, ve, we, c_gn, c_gw, 1.0, force, torque)
        kick(kicked, vel, omega, force, torque, inv_m, inv_i, h, lmask, rmask)
        t += dt
        done += 1
        reason, ok = step_event(done, mx, sm, nc, nleft, e_tol, crit, ok, consecutive, stats, sleeping, n_wake, idx,
                                vel, omega, vel_prev, omega_prev, radius, v_sleep, n_sleep, sleep_count, awake,
                                sleep_ids, step0, sleep_check)
        if reason >= 0:
            return done, reason, t
    return done, DONE, t


@numba.njit(cache=True, error_model="numpy")
def verlet_steps_relisting(nmax, t, idx, pos, vel, omega, vel_prev, omega_prev, force, torque, fp, tp, vp, wp, inv_m,
                           inv_i, lmask, rmask, dt, predict, extrapolate, lo, hi, pa, pb, hist, rhist, touch, radius,
                           mass, inertia, props, awake, active, geom, periodic, wake_speed, wake, wake_ids, n_wake,
                           pl_point, pl_normal, pl_vel, pl_props, pl_hist, pl_rhist, pl_reaction, g, c_gn, c_gw, box,
                           use_box, left_ids, pos_build, half_skin, sleeping, v_sleep, n_sleep, sleep_count,
                           sleep_ids, sleep_check, step0, e_tol, crit, consecutive, ok, stats, law, ncell, single,
                           sgrid, bufs):
    """:func:`verlet_steps` that rebuilds the pair list in place of returning REBUILD
    (:func:`.neighbours.rebuild`, the driver's ``DemSimulation._relist``; *single*: one cell per particle,
    *sgrid*: the current sleeping grid ``DemSimulation._sgrid``, :func:`relisting`); returns (steps done, reason, time, the list pa, pb, hist, rhist,
    touch, the pair buffers)."""
    done = 0
    while True:
        k, why, t = verlet_steps(nmax - done, t, idx, pos, vel, omega, vel_prev, omega_prev, force, torque, fp, tp, vp,
                                 wp, inv_m, inv_i, lmask, rmask, dt, predict, extrapolate, lo, hi, pa, pb, hist, rhist,
                                 touch, radius, mass, inertia, props, awake, active, geom, periodic, wake_speed, wake,
                                 wake_ids, n_wake, pl_point, pl_normal, pl_vel, pl_props, pl_hist, pl_rhist,
                                 pl_reaction, g, c_gn, c_gw, box, use_box, left_ids, pos_build, half_skin, sleeping,
                                 v_sleep, n_sleep, sleep_count, sleep_ids, sleep_check, step0 + done, e_tol, crit,
                                 consecutive, ok, stats, law)
        done += k
        if e_tol >= 0.0 and k:
            ok = int(stats[4])
        if why != REBUILD:
            return done, why, t, pa, pb, hist, rhist, touch, bufs
        pa, pb, hist, rhist, touch, bufs = rebuild(idx, pos, radius, half_skin, geom, periodic, ncell, single, sgrid,
                                                   pa, pb, hist, rhist, pos_build, bufs)


def eligible(sim) -> bool:
    """Whether :func:`run` can advance *sim*: a fixed-step Verlet integrator, fixed planes only, no force
    models, awake particles and known forces (otherwise the driver steps in Python)."""
    from .boundaries import Plane
    from .integrators import VelocityVerlet

    integ = sim.integrator
    return (not sim.models and sim.idx.size > 0 and not sim.forces_stale
            and isinstance(integ, VelocityVerlet) and type(integ).step is VelocityVerlet.step
            and all(type(b) is Plane and b.control == "fixed" for b in sim.boundaries))


def runner(sim):
    """The compiled many-steps runner that can advance *sim* (this module's :func:`run`, or
    :func:`.steploop_fluid.run` for height fields and fluid forces), or None (step in Python)."""
    if eligible(sim):
        return run
    from . import steploop_fluid

    return steploop_fluid.run if steploop_fluid.eligible(sim) else None


def run(sim, nmax: int, e_tol: float = -1.0, crit: int = 0, consecutive: int = 1, ok: int = 0):
    """Advance *sim* (:func:`eligible`) by up to *nmax* steps in one compiled call, with the driver's
    bookkeeping for the event that ended it; returns (steps done, last (max, sum) displacement, ok)."""
    from .contacts import displacement_since as disp_since

    s = sim.state
    if sim._dirty or disp_since(sim.idx, s.pos, sim._pos_build, sim.geom, sim.periodic) > 0.5 * sim.skin:
        sim._rebuild()
    planes = sim.boundaries
    n = s.pos.shape[0]
    pl_hist = np.stack([b.hist for b in planes]) if planes else np.zeros((0, n, 3))
    pl_rhist = np.stack([b.rhist for b in planes]) if planes else np.zeros((0, n, 3))
    pl = [np.array([getattr(b, name) for b in planes], float).reshape(len(planes), width)
          for name, width in (("point", 3), ("normal", 3), ("velocity", 3), ("props", 8))]
    reaction = np.zeros((len(planes), 3))
    integ, w, dt = sim.integrator, sim.work, sim._dt
    sim._n_wake = np.zeros(1, np.int64)
    stats = np.zeros(5)
    n0 = sim.idx.size
    inline = relisting(sim)
    done, why, t, *pairs = (verlet_steps_relisting if inline else verlet_steps)(
        int(nmax), sim.t, sim.idx, s.pos, s.vel, s.omega, s.vel_prev, s.omega_prev, sim.force, sim.torque, w["fp"],
        w["tp"], w["v"], w["w"], sim._inv_m, sim._inv_i, sim.lmask, sim.rmask, dt, bool(integ.predict_velocity),
        float(integ.extrapolate), integ.force_window[0] * dt, integ.force_window[1] * dt, sim._pa, sim._pb,
        sim._hist, sim._rhist, sim._touch, s.radius, s.mass, s.inertia, s._props, s.awake, s.active, sim.geom,
        sim.periodic, sim.wake_velocity, sim._wake_flag, sim._wake_ids, sim._n_wake, pl[0], pl[1], pl[2], pl[3],
        pl_hist, pl_rhist, reaction, sim.gravity.g, s.c_gn, s.c_gw, sim._box, sim._use_box, sim._tmp_ids,
        sim._pos_build, 0.5 * sim.skin, sim.sleeping, sim.sleep_velocity, sim.sleep_steps, sim._sleep_count,
        sim._tmp_ids, sim.sleep_check, sim.steps, float(e_tol), int(crit), int(consecutive), int(ok), stats,
        sim._law, *(relist_args(sim) if inline else ()))
    store_list(sim, pairs)
    return finish(sim, planes, pl_hist, pl_rhist, reaction, done, why, t, stats, n0, e_tol, ok)


def relisting(sim) -> bool:
    """Whether the relisting loops apply: the sleeping grid is current (no sleep, wake or retirement since
    it was built; the driver rebuilds before the call when it is not), so a rebuild inside the compiled
    call (:func:`.neighbours.rebuild`) is the driver's (``DemSimulation._relist``)."""
    return not sim._sleep_grid_dirty and hasattr(sim, "_sgrid")


def relist_args(sim):
    """The extra arguments of the relisting loops: cells per period, one cell per particle or not, the
    sleeping grid and the pair buffers."""
    from .neighbours import empty_buffers

    bufs = getattr(sim, "_pbufs", None) or empty_buffers()
    return sim.ncell, bool(sim.single_bin), sim._sgrid, bufs


def store_list(sim, pairs):
    """Keep the pair list and buffers a relisting loop returned (nothing for the plain loops)."""
    if pairs:
        sim._pa, sim._pb, sim._hist, sim._rhist, sim._touch, sim._pbufs = pairs


def finish(sim, planes, pl_hist, pl_rhist, reaction, done, why, t, stats, n0, e_tol, ok):
    """The driver's bookkeeping after a compiled many-steps call (this module's or
    :mod:`.steploop_fluid`'s) that ended with reason *why*; returns (steps done, last (max, sum)
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
        sim._dirty = True
        sim._sleep_grid_dirty = True
        sim.particle_steps += (done - 1) * n0 + sim.idx.size
    else:
        sim.particle_steps += done * n0
    if why in (LEFT, WAKE) and sim.sleeping:
        sim._sleep_and_wake()
    elif why == SLEEP:
        sim._after_sleep(int(stats[3]))
    return done, (float(stats[0]), float(stats[1])), ok
