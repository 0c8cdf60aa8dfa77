"""Many DEM steps of the closure cycle's scene inside one compiled call (issue 16).

The cycle's DEM (``cycle/driver.py``) has the terrain as a :class:`~.boundaries.HeightField` and the frozen
flow field as a :class:`~breachflow.fluid.forces.FluidForces` model (``static_models``).
:func:`fluid_verlet_steps` is the one compiled loop of :mod:`.steploop` (which runs it for dry scenes
without these) with, in the order of ``DemSimulation._one_step``: the height-field contacts
(:func:`.wall_contacts.heightfield_forces`, in the boundaries' order among fixed planes), gravity, the fluid
forces (:func:`breachflow.fluid.compiled.grid_fluid_forces_phi`: buoyancy, drag with the vertical
velocity profile, convective apparent mass, gridpoint torque, into ``sim._fm``/``_tm`` and then added) and
the global damping; the inverse mass ``1/(m + m_added)`` of the kicks is the integrators'
(:meth:`~.simulation.DemSimulation.inverse_mass`). The field is sampled once per step for the moving masses:
the apparent mass of the next step (at the same positions) reuses the submerged fraction of this step's
force evaluation (:func:`breachflow.fluid.compiled.apparent_mass`, the formula of
:func:`~breachflow.fluid.compiled.grid_added_masses`). The kernels are the ones the Python path calls, in
the same order, so the results are bit-identical (tests/dem/test_steploop_fluid.py).

The fixed planes' contact loops run over candidate lists (:func:`list_planes`, LAMMPS keeps neighbour lists
of walls alike): built with the pair list, from the build positions, they hold the awake particles whose
gap to the plane was below the skin ``margin`` or whose plane histories are not +0.0. Each step checks that
no particle left out can reach its plane: it moved at most ``moved`` since the build (measured after the
drift by ``first_pass``) and the step-averaged law looks ``max(-lo, hi) |v . n|`` further
(``|v|`` at most ``mx / dt`` for ``velocity_verlet``, the predicted velocities' maximum for ``predicted_verlet``),
which must stay below the margin (:func:`.wall_contacts.candidates_hold`). If it does not, that step and all up to
the next build run over all particles, as the Python step does. The particles left out are far, as the full
loop would find them, and their history rows +0.0, as it would leave them: the results are bit-identical
(tests/dem/test_plane_candidates.py). A plane whose normal has a component along a periodic axis has no list.

:func:`eligible` says when it applies: a fixed-step Verlet integrator, fixed planes and at most one height
field, no force model or one ``FluidForces`` whose fused kernels apply (a
non-uniform grid snapshot, no Basset term, particles outside the grid see air, no fallback sampler;
``FluidForces._fused_args``) with
``static_models`` on and the sleepers' force check done. Otherwise (nested fallback sampler, a mesh or
uniform field, Basset, ``outside="error"``, the report scheme, ``adaptive_free_flight``, moving planes,
non-static models) the simulation steps in Python.
"""
from __future__ import annotations

import numba
import numpy as np

from ..fluid.compiled import apparent_mass, grid_added_masses, grid_fluid_forces_phi
from ..dem.contact_law import STEP_AVERAGED
from ..dem.pair_contacts import heightfield_forces, pair_forces_interval, plane_forces
from ..dem.forces import _add_gravity, zero_rows
from ..dem.neighbours import displacement_since, rebuild
from ..dem.steploop import BAD, DONE, any_damping, close_and_first_pass, first_pass, next_ok, second_pass, step_event
from ..dem.wall_contacts import candidates_hold, plane_candidates


@numba.njit(cache=True, error_model="numpy")
def _inverse_masses(idx, mass, radius, phi, xi, rho_w, rho_a, inv_m):
    """``inv_m[i] = 1/(m_i + apparent mass)`` of particles ``idx[k]`` with submerged fractions ``phi[k]``; *xi*
    (N,) each particle's apparent-mass coefficient."""
    for k in range(idx.shape[0]):
        i = idx[k]
        inv_m[i] = 1.0 / (mass[i] + apparent_mass(xi[i], radius[i], phi[k], rho_w, rho_a))


@numba.njit(cache=True, error_model="numpy")
def list_planes(idx, pos_build, radius, pl_point, pl_normal, margin, pl_hist, pl_rhist, listable, cand, ncand):
    """The candidate lists of the fixed planes (:func:`.wall_contacts.plane_candidates` with *margin*) into the rows
    of *cand*, their lengths into *ncand*; a plane not *listable* lists none (its loop runs over all)."""
    for p in range(pl_point.shape[0]):
        ncand[p] = plane_candidates(idx, pos_build, radius, pl_point[p], pl_normal[p], margin, pl_hist[p],
                                    pl_rhist[p], cand[p]) if listable[p] else 0


@numba.njit(cache=True, error_model="numpy")
def fluid_verlet_steps(nmax, t, idx, pos, vel, omega, vel_prev, omega_prev, force, torque, fp, tp, vp, wp, inv_m,
                       inv_i, lmask, rmask, dt, predict, extrapolate, lo, hi, pa, pb, hist, rhist, touch, radius,
                       mass, inertia, props, awake, active, geom, periodic, wake_speed, wake, wake_ids, n_wake,
                       planes, hf_at, hf, fluid_on, field, fluid, fm, tm, g, c_gn, c_gw, box, use_box, left_ids,
                       pos_build, half_skin, sleeping, v_sleep, n_sleep, sleep_count, sleep_ids, sleep_check, step0,
                       e_tol, crit, consecutive, ok, stats, law, ncell, single, sgrid, bufs):
    """Up to *nmax* Verlet steps (kick, drift, wrap, contacts, boundaries, gravity, fluid forces, damping, kick)
    of the awake particles *idx*, rebuilding the pair list *pa*, *pb*, *hist*, *rhist*, *touch* after the drift,
    before the forces, when some awake particle moved more than *half_skin* since the build less the interval
    law's reach ``max(-lo, hi) max|v|`` (so no unlisted pair is in contact within the interval at the force
    evaluation, ``PairList.relist_after_drift``; :func:`.neighbours.rebuild` with cells per period *ncell*,
    one cell per particle or not *single*, the current sleeping grid *sgrid* and the pair buffers *bufs*);
    returns (steps done, reason, time, the list pa, pb, hist, rhist, touch, the pair buffers).

    *stats* (out): [max, sum displacement of the last step, contacts, #left / #woken / #asleep / bad id,
    consecutive steps below *e_tol*]; ``e_tol < 0``: no equilibrium test. *crit* 0: max criterion, 1: sum.
    ``ok``: consecutive steps below e_tol so far. *law*: kernel code of the contact law
    (:data:`breachflow.dem.contact_law.contact_laws`).

    *planes* ``(point, normal, velocity, props, hist, rhist, reaction)`` stacked per fixed plane; *hf_at*
    the position of the height field among the boundaries (-1: none), *hf* its ``(x0, y0, hx, hy, bed,
    props, hist, rhist)``; *fluid_on* whether there is a fluid model, *field* its fused field arguments
    (``FluidForces._fused``), *fluid* ``(wind, rho_w, nu_w, rho_a, nu_a, with_air, gravity, law, params,
    own drag coefficients, own lift coefficients, apparent-mass coefficients (N,), time_step, torque, rho_a_added)``; *fm*, *tm* the model force/torque rows (``sim._fm``/``_tm``);
    *inv_m* receives the inverse masses with the apparent mass (``sim._inv_m_added``, or ``sim._inv_m``
    without fluid, then untouched).
    """
    pl_point, pl_normal, pl_vel, pl_props, pl_hist, pl_rhist, pl_reaction = planes
    hx0, hy0, hhx, hhy, hbed, hprops, hhist, hrhist = hf
    method, bed, depth, u, v, x0, y0, dx, dy, smax, outside_air, profile, k_s, bedp = field
    wind, rho_w, nu_w, rho_a, nu_a, with_air, grav, dlaw, params, cds, cls, xi, time_step, do_torque, rho_am = fluid
    nb = pl_point.shape[0] + (1 if hf_at >= 0 else 0)
    phi = np.empty(idx.shape[0])
    if fluid_on:  # the apparent mass at the start positions (as DemSimulation.inverse_mass)
        grid_added_masses(idx, pos, radius, method, bed, depth, u, v, x0, y0, dx, dy, smax, outside_air, profile,
                          k_s, bedp, rho_w, rho_am, xi, phi)
        for k in range(idx.shape[0]):
            i = idx[k]
            inv_m[i] = 1.0 / (mass[i] + phi[k])
    h = 0.5 * dt
    done = 0
    damp = any_damping(idx, c_gn, c_gw)  # else the damping pass is skipped (second_pass)
    moved = displacement_since(idx, pos, pos_build, geom, periodic)
    # the fixed planes' loops run over candidate lists (module docstring), rebuilt with the pair list
    npl = pl_point.shape[0]
    margin = 2.0 * half_skin
    reach_t = max(-lo, hi) if law == STEP_AVERAGED else 0.0
    listable = np.empty(npl, np.bool_)
    for p in range(npl):  # a plane across a periodic axis: a wrapped particle jumps, no lists
        listable[p] = not ((periodic[0] and pl_normal[p, 0] != 0.0) or (periodic[1] and pl_normal[p, 1] != 0.0))
    cand = np.empty((npl, idx.shape[0]), np.int64)
    ncand = np.zeros(npl, np.int64)
    listed = npl > 0 and margin > 0.0 and moved <= half_skin
    if listed:
        list_planes(idx, pos_build, radius, pl_point, pl_normal, margin, pl_hist, pl_rhist, listable, cand, ncand)
    opened = False  # this step's first pass done by the last step's closing pass (close_and_first_pass)
    for _ in range(nmax):
        if not opened:
            n_wake[0] = 0
            bad, nleft, idx, kicked, ve, we, mx, sm, moved, vpmax = first_pass(
                idx, pos, vel, omega, force, torque, fp, tp, vp, wp, inv_m, inv_i, lmask, rmask, h, dt, predict,
                extrapolate, geom, periodic, box, use_box, active, awake, left_ids, pos_build)
        opened = False
        if bad >= 0:
            stats[3] = bad
            return done, BAD, t, pa, pb, hist, rhist, touch, bufs
        # how far beyond the gap the interval law looks (max(-lo, hi) |v|: each particle in its half of the skin)
        reach = 0.0 if reach_t == 0.0 else reach_t * (vpmax if predict else mx / dt)
        if moved + reach > half_skin:  # after the drift, before the forces (LAMMPS' Verlet: neighbor->decide())
            pa, pb, hist, rhist, touch, bufs = rebuild(idx, pos, radius, half_skin, geom, periodic, ncell, single,
                                                       sgrid, pa, pb, hist, rhist, pos_build, bufs)
            moved = 0.0  # the build positions are these
            listed = npl > 0 and margin > 0.0
            if listed:
                list_planes(idx, pos_build, radius, pl_point, pl_normal, margin, pl_hist, pl_rhist, listable, cand,
                            ncand)
        elif listed and nleft:  # leavers retired from idx: from the lists too
            list_planes(idx, pos_build, radius, pl_point, pl_normal, margin, pl_hist, pl_rhist, listable, cand, ncand)
        if listed:  # else the loops run over all and the lists are stale (histories set) until the next build
            listed = candidates_hold(moved, reach, margin)
        nc = pair_forces_interval(pa, pb, hist, rhist, touch, pos, ve, we, vel, omega, predict, radius, mass, inertia,
                                props, awake, active, geom, periodic, dt, wake_speed, force, torque, wake, wake_ids,
                                n_wake, lo, hi, law)
        p = 0
        for b in range(nb):
            if b == hf_at:
                nc += heightfield_forces(idx, hx0, hy0, hhx, hhy, hbed, hprops, hhist, hrhist, pos, ve, we, radius,
                                         mass, inertia, props, dt, force, torque, lo, hi, vel, omega, law)
                continue
            pl_reaction[p, :] = 0.0
            nc += plane_forces(cand[p, :ncand[p]] if listed and listable[p] else idx, pl_point[p], pl_normal[p],
                               pl_vel[p], pl_props[p], pl_hist[p], pl_rhist[p], pos, ve, we, radius, mass, inertia,
                               props, dt, force, torque, pl_reaction[p], lo, hi, vel, omega, law)
            p += 1
        if fluid_on:  # static models: the awake rows of _fm/_tm, then added (DemSimulation.body_forces)
            _add_gravity(idx, mass, g, force)
            zero_rows(idx, fm, tm)
            grid_fluid_forces_phi(idx, pos, ve, we, pos, awake, radius, method, bed, depth, u, v, x0, y0, dx, dy,
                                  smax, outside_air, profile, k_s, bedp, wind, rho_w, nu_w, rho_a, nu_a, with_air, grav,
                                  dlaw, params, cds, cls, xi, time_step, do_torque, fm, tm, phi)
            for k in range(idx.shape[0]):
                i = idx[k]
                for d in range(3):
                    force[i, d] += fm[i, d]
                    torque[i, d] += tm[i, d]
        t += dt
        done += 1
        if (done < nmax and nleft == 0 and not fluid_on and not sleeping
                and not (e_tol >= 0.0 and next_ok(mx, sm, e_tol, crit, ok) >= consecutive)):
            # no event ends the call after this step (step_event, whose sleep test needs the closed
            # velocities, runs before the closing kick): close it and open the next one in one pass
            reason, ok = step_event(done, mx, sm, nc, nleft, e_tol, crit, ok, consecutive, stats, sleeping, n_wake,
                                    idx, vel, omega, vel_prev, omega_prev, radius, v_sleep, n_sleep, sleep_count,
                                    awake, sleep_ids, step0, sleep_check)
            n_wake[0] = 0
            bad, nleft, idx, kicked, ve, we, mx, sm, moved, vpmax = close_and_first_pass(
                idx, pos, vel, omega, force, torque, fp, tp, vp, wp, inv_m, inv_i, lmask, rmask, h, dt, predict,
                extrapolate, geom, periodic, box, use_box, active, awake, left_ids, pos_build, True, True, mass, g,
                c_gn, c_gw, damp)
            opened = True
            continue
        # gravity (dry scenes: here), global damping and the closing kick in one pass
        second_pass(kicked, active, not fluid_on, mass, g, ve, we, c_gn, c_gw, damp, force, torque, vel, omega, inv_m,
                    inv_i, h, lmask, rmask)
        if fluid_on:  # next step's apparent mass, at these positions
            _inverse_masses(idx, mass, radius, phi, xi, rho_w, rho_am, inv_m)
        reason, ok = step_event(done, mx, sm, nc, nleft, e_tol, crit, ok, consecutive, stats, sleeping, n_wake, idx,
                                vel, omega, vel_prev, omega_prev, radius, v_sleep, n_sleep, sleep_count, awake,
                                sleep_ids, step0, sleep_check)
        if reason >= 0:
            return done, reason, t, pa, pb, hist, rhist, touch, bufs
    return done, DONE, t, pa, pb, hist, rhist, touch, bufs


def _fluid_model(sim):
    """The simulation's one fused ``FluidForces`` model, None without models, False if not eligible."""
    from ..fluid.forces import FluidForces

    if not sim.models:
        return None
    m = sim.models[0]
    if (len(sim.models) != 1 or type(m) is not FluidForces or m._fused is None or not m._fused[10]
            or not sim.static_models or not sim._models_checked):
        return False
    return m


def eligible(sim) -> bool:
    """Whether :func:`run` can advance *sim* (module docstring): a fixed-step Verlet integrator, fixed planes
    and at most one height field, no force model or one fused static ``FluidForces``, awake particles and
    known forces."""
    from ..dem.boundaries import HeightField, Plane
    from ..dem.integrators import VelocityVerlet

    integ = sim.integrator
    if (sim.idx.size == 0 or sim.forces_stale or not isinstance(integ, VelocityVerlet)
            or type(integ).step is not VelocityVerlet.step):
        return False
    n_hf = 0
    for b in sim.boundaries:
        if type(b) is HeightField:
            n_hf += 1
        elif not (type(b) is Plane and b.control == "fixed"):
            return False
    return n_hf <= 1 and _fluid_model(sim) is not False


_NO_FIELD = (0, np.zeros((1, 1)), np.zeros((1, 1)), np.zeros((1, 1)), np.zeros((1, 1)), 0.0, 0.0, 1.0, 1.0, 0.0,
             True, 0, 1.0, np.zeros(7))


def run(sim, nmax: int, e_tol: float = -1.0, crit: int = 0, consecutive: int = 1, ok: int = 0):
    """Advance *sim* (:func:`eligible`) by up to *nmax* steps in one compiled call, with the driver's
    bookkeeping for the event that ended it (:func:`.steploop.finish`); returns (steps done, last (max,
    sum) displacement, ok)."""
    from ..dem import steploop
    from ..dem.boundaries import HeightField

    s = sim.state
    steploop.current_list(sim)
    n = s.pos.shape[0]
    hf_at, hf = -1, (0.0, 0.0, 1.0, 1.0, np.zeros((1, 1)), np.zeros(8), np.zeros((1, 3)), np.zeros((1, 3)))
    planes = []
    for k, b in enumerate(sim.boundaries):
        if type(b) is HeightField:
            hf_at, hf = k, (b.x0, b.y0, b.hx, b.hy, b.bed, b.props, b.hist, b.rhist)
        else:
            planes.append(b)
    pl_hist = np.stack([b.hist for b in planes]) if planes else np.zeros((0, n, 3))
    pl_rhist = np.stack([b.rhist for b in planes]) if planes else np.zeros((0, n, 3))
    pl = [np.array([getattr(b, name) for b in planes], float).reshape(len(planes), width)
          for name, width in (("point", 3), ("normal", 3), ("velocity", 3), ("props", 8))]
    reaction = np.zeros((len(planes), 3))
    model = _fluid_model(sim)
    if model is not None:
        if sim._inv_m_added.shape[0] != n:
            sim._inv_m_added = np.zeros(n)
        inv_m = sim._inv_m_added
        air = model.air if model.air is not None else model.water
        fluid = (model.wind, model.water.rho, model.water.nu, air.rho, air.nu, model.air is not None, model.gravity,
                 model.drag_law.law_id, model.drag_law.params, *model.own_coefficients(s), model.apparent_coefficients(s),
                 model.time_step or 0.0, model.torque,
                 0.0 if model.air is None else model.air.rho)
        field = model._fused
    else:
        inv_m = sim._inv_m
        fluid = (np.zeros(3), 1.0, 1.0, 1.0, 1.0, False, 0.0, 0, np.zeros(1), np.zeros(1), np.zeros(1), np.zeros(1),
                 0.0, False, 0.0)
        field = _NO_FIELD
    integ, w, dt = sim.integrator, sim.work, sim._dt
    nl, sl = sim.pairs, sim.sleepers
    sl.n_wake = np.zeros(1, np.int64)
    stats = np.zeros(5)
    n0 = sim.idx.size
    done, why, t, *pairs = fluid_verlet_steps(
        int(nmax), sim.t, sim.idx, s.pos, s.vel, s.omega, s.vel_prev, s.omega_prev, sim.force, sim.torque, w["fp"],
        w["tp"], w["v"], w["w"], inv_m, sim._inv_i, sim.lmask, sim.rmask, dt, bool(integ.predict_velocity),
        float(integ.extrapolate), integ.force_interval[0] * dt, integ.force_interval[1] * dt, nl.pa, nl.pb,
        nl.hist, nl.rhist, nl.touch, s.radius, s.mass, s.inertia, s._props, s.awake, s.active, sim.geom,
        sim.periodic, sim.wake_velocity, sl.wake_flag, sl.wake_ids, sl.n_wake,
        (pl[0], pl[1], pl[2], pl[3], pl_hist, pl_rhist, reaction), hf_at, hf, model is not None, field, fluid,
        sim._fm, sim._tm, sim.gravity.g, s.c_gn, s.c_gw, sim._box, sim._use_box, sim._tmp_ids, nl.pos_build,
        0.5 * sim.skin, sim.sleeping, sim.sleep_velocity, sim.sleep_steps, sl.count, sim._tmp_ids,
        sim.sleep_check, sim.steps, float(e_tol), int(crit), int(consecutive), int(ok), stats, sim._law,
        *steploop.relist_args(sim))
    nl.pa, nl.pb, nl.hist, nl.rhist, nl.touch, nl.bufs = pairs
    if model is not None:
        model.evaluations += done
    return steploop.finish(sim, planes, pl_hist, pl_rhist, reaction, done, why, t, stats, n0, e_tol, ok)
