"""The DEM driver: particles, boundaries, force models, neighbour lists, sleeping (docs/theory.md, *DEM contact*, *The closure cycle*).

>>> rock = Material(density=2650, kn=1e7, friction=0.5, c_cn=4e4)
>>> sim = DemSimulation(boundaries=[Plane((0, 0, 0), (0, 0, 1), rock)])
>>> _ = sim.add_particles([[0.0, 0.0, 2.0]], radius=0.5, material=rock)
>>> result = sim.run_to_equilibrium(e_tol=1e-6)
>>> result.converged
True

The driver holds the set-up, the force assembly the integrators call and the stepping; by concept, its
other parts are components in their own modules, held as attributes:

- ``pairs``, a :class:`.pairlist.PairList` — the neighbour list: pairs closer than ``skin`` are listed and reused until some awake
  particle has moved more than ``skin/2`` (less the interval law's reach) or particles fell asleep / woke /
  were inserted; each pair keeps its shear and rolling histories across steps and rebuilds (parked while
  both partners sleep);
- ``sleepers``, a :class:`.sleeping.Sleepers` — sleeping and waking (docs/theory.md, *DEM contact*): slow particles are put to sleep (not integrated,
  still contact partners) and woken by a moving contact, a moving boundary or a change of the force
  models' force; :meth:`DemSimulation.sleep` puts given particles to sleep at once;
- :mod:`.checkpoint` — :meth:`DemSimulation.save_state` / :meth:`DemSimulation.from_state` round-trip
  everything for a bit-identical continuation; :meth:`DemSimulation.memory_bytes`.
"""
from __future__ import annotations

import inspect
import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError, PhysicsError
from . import neighbours, pair_contacts, steploop
from .boundaries import Boundary, Plane  # Plane: the example above
from . import checkpoint
from .contact_law import contact_laws, resolve as resolve_contact_law
from .forces import G, ForceModel, Gravity, add_global_damping, zero_rows
from .integrators import integrators
from .contact_law import STEP_AVERAGED
from .pairlist import PairList
from .sleeping import Sleepers
from .state import UNSET, Material, ParticleState
from .timestep import SAFETY, check_dt, stable_dt


@dataclass
class EquilibriumResult:
    """Outcome of :meth:`DemSimulation.run_to_equilibrium` (report Step 11)."""

    converged: bool
    steps: int
    time: float
    displacement: float  # last per-step max or sum displacement (m)
    particle_steps: int  # sum over steps of the number of integrated (awake) particles


class DemSimulation:
    """A DEM scene of spheres.

    Parameters (SI): ``boundaries`` planes / height fields; ``models`` extra :class:`~breachflow.dem.forces.ForceModel` s (fluid);
    ``gravity`` vector (m/s^2); ``integrator`` name in ``breachflow.integrators`` or an instance;
    ``dt`` (s; default ``SAFETY * stable limit``, a larger one than the limit is refused);
    ``periodic_x``/``periodic_y`` ``(lo, hi)`` periodic ranges; ``domain`` ``(xmin, xmax, ymin, ymax,
    zmin, zmax)`` — particles leaving it are deactivated and listed in ``left_domain``;
    ``skin`` neighbour-list skin (m; default 0.1 median diameter); ``cell_size`` grid cell (m; default
    median diameter + skin); ``sleeping`` on/off; ``plane_2d`` restricts motion to the x–z plane
    (translation in x, z and rotation about y; the report's 2-D setting; out-of-plane components of
    inserted velocities are dropped); ``contact_law`` name in ``breachflow.contact_laws``
    (:data:`.contact_law.contact_laws`: ``step_averaged``, the default, or LAMMPS' ``hooke_history``).
    """

    def __init__(self, state: ParticleState | None = None, *, boundaries=(), models=(), gravity=(0.0, 0.0, -G),
                 integrator=integrators.default, dt: float | None = None, periodic_x=None, periodic_y=None,
                 domain=None, skin: float | None = None, cell_size: float | None = None, sleeping: bool = True,
                 sleep_velocity: float = 1e-3, wake_velocity: float | None = None, sleep_steps: int = 100,
                 sleep_check: int = 25,
                 wake_force_fraction: float = 0.05, static_models: bool = False,
                 plane_2d: bool = False, contact_law=contact_laws.default):
        self.state = state if state is not None else ParticleState.empty()
        self.boundaries: list[Boundary] = list(boundaries)
        self.models: list[ForceModel] = list(models)
        for m in self.models:
            if not isinstance(m, ForceModel):
                raise InputError(f"force model {m!r} lacks added_mass/accumulate (ForceModel protocol)")
        self.gravity = Gravity(gravity)
        self.integrator = integrators.create(integrator)
        self.contact_law = resolve_contact_law(contact_law)
        self._law = int(self.contact_law.code)  # kernel code of the contact law
        self._user_dt = dt
        self.periodic = np.array([periodic_x is not None, periodic_y is not None], dtype=np.int64)
        self._period_ranges = (periodic_x, periodic_y)
        self._box = np.zeros(6) if domain is None else np.asarray(domain, float)
        if self._box.shape != (6,):
            raise InputError("domain must be (xmin, xmax, ymin, ymax, zmin, zmax)")
        self._use_box = domain is not None
        self._skin_user, self._cell_user = skin, cell_size
        self.sleeping = bool(sleeping)
        self.sleep_velocity = float(sleep_velocity)
        self.wake_velocity = 10.0 * self.sleep_velocity if wake_velocity is None else float(wake_velocity)
        self.sleep_steps = int(sleep_steps)
        self.sleep_check = max(1, int(sleep_check))
        self.wake_force_fraction = float(wake_force_fraction)
        # static_models: the force models do not change in time (a frozen flow field, docs/theory.md, *The closure cycle*), so a
        # sleeper's model force is checked once, on the first step, and then only awake particles are
        # evaluated (their accumulate must accept idx=); per-step cost then follows the moving particles
        self.static_models = bool(static_models)
        self._models_checked = False
        self._row_models = [_accepts_idx(m.added_mass) for m in self.models]
        self._inv_m_added = np.zeros(0)
        self.lmask = np.array([1.0, 0.0, 1.0]) if plane_2d else np.ones(3)
        self.rmask = np.array([0.0, 1.0, 0.0]) if plane_2d else np.ones(3)
        #: run fixed-step Verlet scenes without force models many steps per compiled call (:mod:`.steploop`,
        #: bit-identical to stepping in Python, which ``compiled = False`` forces)
        self.compiled = True
        self.t = 0.0
        self.steps = 0
        self.particle_steps = 0
        self.left_domain: list[int] = []
        self.n_contacts = 0
        self._n = 0
        #: the neighbour list (:class:`.pairlist.PairList`) and the sleeping / waking (:class:`.sleeping.Sleepers`)
        self.pairs = PairList(self)
        self.sleepers = Sleepers(self)
        self._alloc(self.state.n)
        self._set_geometry()
        self._dt = None
        if self.state.n:
            self._on_added(np.arange(self.state.n))

    # ------------------------------------------------------------------ set-up
    def _alloc(self, n):
        def grow(a, shape, dtype=float):
            new = np.zeros(shape, dtype)
            if a is not None:
                new[: a.shape[0]] = a
            return new

        g = lambda name, shape, dtype=float: setattr(self, name, grow(getattr(self, name, None), shape, dtype))
        for name in ("force", "torque", "_fm", "_tm"):
            g(name, (n, 3))
        g("_fixed", (n,), bool)
        g("_tmp_ids", (n,), np.int64)
        self.pairs.resize(n)
        self.sleepers.resize(n)
        self.work = {k: grow(getattr(self, "work", {}).get(k), (n, 3)) for k in ("v", "w", "x", "fc", "tc", "fp", "tp")}
        for b in self.boundaries:
            b.resize(n)
        self._n = n

    def _set_geometry(self):
        s = self.state
        act = s.radius[s.active] if s.n else np.array([0.5])
        d_med = 2.0 * float(np.median(act)) if act.size else 1.0
        self.skin = float(self._skin_user) if self._skin_user is not None else 0.1 * d_med
        r_max = float(act.max()) if act.size else 0.5
        # nearly uniform sizes: one cell per particle, cells >= the largest reach, 27-cell search;
        # otherwise cells follow the median size and large particles are binned in every cell they touch
        self.single_bin = self._cell_user is None and r_max <= 0.75 * d_med
        if self.single_bin:
            h = 2 * r_max + self.skin
        else:
            h = float(self._cell_user) if self._cell_user is not None else d_med + self.skin
        self.geom = np.array([0.0, 0.0, 0.0, h, h, h, 1.0, 1.0])
        self.ncell = np.array([1, 1], np.int64)
        rmax = float(act.max()) if act.size else 0.5
        for d, rng in enumerate(self._period_ranges):
            if rng is None:
                continue
            lo, hi = float(rng[0]), float(rng[1])
            L = hi - lo
            if not L > 0:
                raise InputError(f"periodic range {rng} must have hi > lo")
            if L < 2.0 * (2.0 * rmax + self.skin) + 2 * h:
                raise InputError(f"periodic length {L} m too short for particles of radius {rmax} m "
                                 f"(need >= {2 * (2 * rmax + self.skin) + 2 * h:.3g} m)")
            n = max(1, int(L // h))
            self.geom[d], self.geom[3 + d], self.geom[6 + d], self.ncell[d] = lo, L / n, L, n
        self.pairs.invalidate()

    def add_particles(self, pos, radius, material: Material | None = None, vel=None, omega=None, *,
                      drag_coefficient=UNSET, lift_coefficient=UNSET, added_mass_coefficient=UNSET) -> np.ndarray:
        """Insert spheres (SI); returns their indices. They start awake. *drag_coefficient*,
        *lift_coefficient*, *added_mass_coefficient*: the particles' own fluid parameters
        (:class:`~.state.ParticleState`; unset: the force model's)."""
        idx = self.state.add(pos, radius, material, vel=vel, omega=omega, drag_coefficient=drag_coefficient,
                             lift_coefficient=lift_coefficient, added_mass_coefficient=added_mass_coefficient)
        self._on_added(idx)
        return idx

    def _on_added(self, idx):
        s = self.state
        if s.n > self._n:
            self._alloc(s.n)
        # 2-D mode: only in-plane motion exists (out-of-plane velocity/spin components are dropped)
        s.vel[idx] *= self.lmask
        s.vel_prev[idx] *= self.lmask
        s.omega[idx] *= self.rmask
        s.omega_prev[idx] *= self.rmask
        self._inv_m = 1.0 / s.mass
        self._inv_i = 1.0 / s.inertia
        self.force[idx] = s.mass[idx, None] * self.gravity.g * self.lmask
        self.torque[idx] = 0.0
        self.forces_stale = True
        limit = stable_dt(s.mass[s.active], s.kn[s.active], s.ks[s.active], s.c_cn[s.active],
                          wall_kn=[b.material.kn for b in self.boundaries],
                          rolling_friction=s.rolling_friction[s.active])
        self.dt_limit = limit
        if self._user_dt is not None:
            self._dt = check_dt(float(self._user_dt), limit)
        else:
            self._dt = SAFETY * limit
        if self._cell_user is None or self._skin_user is None or self.steps == 0:
            self._set_geometry()
        self.pairs.invalidate()
        self._refresh_idx()
        self._commit_models()

    def _commit_models(self):
        """Tell force models with a memory (the Basset history) the accepted state."""
        for m in self.models:
            commit = getattr(m, "commit", None)
            if commit is not None:
                commit(self.state, self.state.pos, self.state.vel, self.t)

    @property
    def dt(self) -> float:
        return self._dt

    def _refresh_idx(self):
        s = self.state
        self.idx = np.flatnonzero(s.awake & s.active).astype(np.int64)

    @property
    def n_awake(self) -> int:
        return int(self.idx.size)

    # ------------------------------------------------------------------ force assembly (integrators)
    def inverse_mass(self, added: bool = True):
        """(1/(m + sum added mass), 1/I) per particle. With ``static_models`` only the awake rows (the
        ones the integrators read) are filled, and a model whose ``added_mass`` accepts ``idx=`` (returning
        those rows) is evaluated only there, so the per-step cost follows the moving particles."""
        if added and self.models:
            if self.static_models:
                i = self.idx
                extra = np.zeros(i.size)
                for m, rows in zip(self.models, self._row_models):
                    a = m.added_mass(self.state, idx=i) if rows else m.added_mass(self.state)
                    if a is not None:
                        extra += a if rows else a[i]
                if self._inv_m_added.shape[0] != self.state.n:
                    self._inv_m_added = np.zeros(self.state.n)
                self._inv_m_added[i] = 1.0 / (self.state.mass[i] + extra)
                return self._inv_m_added, self._inv_i
            extra = np.zeros(self.state.n)
            for m in self.models:
                a = m.added_mass(self.state)
                if a is not None:
                    extra += a
            return 1.0 / (self.state.mass + extra), self._inv_i
        return self._inv_m, self._inv_i

    def set_models(self, models) -> None:
        """Replace the force models (e.g. the frozen flow field of the next closure cycle), as if the
        simulation were restored with :meth:`from_state` and the new *models*: with ``static_models``
        the sleepers' reference forces are compared with the new models at the next step."""
        models = list(models)
        for m in models:
            if not isinstance(m, ForceModel):
                raise InputError(f"force model {m!r} lacks added_mass/accumulate (ForceModel protocol)")
        self.models = models
        self._row_models = [_accepts_idx(m.added_mass) for m in models]
        self._models_checked = False

    def contact_forces(self, pos, vel, omega, force, torque, interval=(0.0, 0.0), vel_h=None, omega_h=None):
        """Zero the awake rows of force/torque, then add all contact forces (particles and boundaries).

        Called once per step: it advances the shear histories by one step. *interval* ``(lo, hi)`` in
        steps: the interval around the evaluation time over which the integrator applies these forces
        (``(-1/2, 1/2)`` for kick–drift–kick Verlet); contact forces are averaged over it so that contact
        onset and release inside a step are resolved (:func:`.contact_law.contact_law`). ``(0, 0)``: point values.
        *vel*, *omega*: velocities at the evaluation time (dashpots); *vel_h*, *omega_h* (default: the same):
        the velocities that moved the positions over the step, which advance the shear histories.
        """
        s = self.state
        zero_rows(self.idx, force, torque)
        sl, pl = self.sleepers, self.pairs
        sl.n_wake[0] = 0
        lo, hi = interval[0] * self._dt, interval[1] * self._dt
        split = vel_h is not None and vel_h is not vel
        vel_h = vel if vel_h is None else vel_h
        omega_h = omega if omega_h is None else omega_h
        n = pair_contacts.pair_forces_interval(pl.pa, pl.pb, pl.hist, pl.rhist, pl.touch, pos, vel, omega,
                                        vel_h, omega_h, split, s.radius, s.mass, s.inertia, s._props, s.awake,
                                        s.active, self.geom, self.periodic, self._dt, self.wake_velocity, force,
                                        torque, sl.wake_flag, sl.wake_ids, sl.n_wake, lo, hi, self._law)
        view = _StateView(s, pos, vel, omega, vel_h, omega_h)
        for b in self.boundaries:
            n += b.forces(self.idx, view, self._dt, force, torque, lo, hi, self._law)
        self.n_contacts = n

    def refresh_forces(self):
        """Evaluate force/torque at the current state without advancing shear histories (Verlet's first
        half kick needs F(t) of inserted or woken particles)."""
        s = self.state
        pl = self.pairs
        saved = [(pl.hist.copy(), pl.rhist.copy())] + [(b.hist.copy(), b.rhist.copy()) for b in self.boundaries]
        dt, self._dt = self._dt, 0.0
        try:
            self.contact_forces(s.pos, s.vel, s.omega, self.force, self.torque)
        finally:
            self._dt = dt
            pl.hist[:], pl.rhist[:] = saved[0]
            for b, (h, rh) in zip(self.boundaries, saved[1:]):
                b.hist[:] = h
                b.rhist[:] = rh
        self.sleepers.n_wake[0] = 0
        self.body_forces(s.pos, s.vel, s.omega, self.t, self.force, self.torque)
        self.global_damping(s.vel, s.omega, self.force, self.torque, 1.0)
        self.forces_stale = False

    def body_forces(self, pos, vel, omega, t, force, torque):
        """Add gravity and every force model at the given kinematic state."""
        self.gravity.accumulate(self.state, pos, vel, omega, t, force, torque, idx=self.idx)
        if self.models:
            i = self.idx
            if self.static_models and self._models_checked:
                self._fm[i] = 0.0
                self._tm[i] = 0.0
                for m in self.models:
                    m.accumulate(self.state, pos, vel, omega, t, self._fm, self._tm, idx=i)
            else:
                self._fm[:] = 0.0
                self._tm[:] = 0.0
                for m in self.models:
                    m.accumulate(self.state, pos, vel, omega, t, self._fm, self._tm)
            force[i] += self._fm[i]
            torque[i] += self._tm[i]

    def global_damping(self, vel, omega, force, torque, scale):
        s = self.state
        add_global_damping(self.idx, vel, omega, s.c_gn, s.c_gw, float(scale), force, torque)

    # ------------------------------------------------------------------ stepping
    def step(self, n: int = 1):
        """Advance *n* steps of ``dt``; returns the last (max, sum) per-step displacement (m)."""
        disp = (0.0, 0.0)
        left = int(n)
        while left > 0:
            done = 0
            run = steploop.runner(self) if self.compiled else None
            if run is not None:  # many steps in one compiled call
                done, disp, _ = run(self, left)
            if done == 0:
                disp = self._one_step()
                done = 1
            left -= done
        return disp

    def _one_step(self, t_limit: float = math.inf):
        s = self.state
        self.sleepers.n_wake = np.zeros(1, np.int64)
        self.sleepers.wake_from_boundaries()
        first_static = self.static_models and not self._models_checked
        if self.models and self.state.n and (first_static or (self.idx.size == 0 and self.sleeping
                                                              and not self.static_models)):
            # nothing integrated evaluates the models for sleepers (or, with static models, the first
            # step after set-up / restore must compare the current field with the sleepers' reference)
            s = self.state
            self._fm[:] = 0.0
            self._tm[:] = 0.0
            for m in self.models:
                m.accumulate(s, s.pos, s.vel, s.omega, self.t, self._fm, self._tm)
            self.sleepers.wake_by_force()
            self._models_checked = True
        if self.idx.size == 0:
            self.t += self._dt
            self.steps += 1
            for b in self.boundaries:
                b.advance(self._dt)
            return (0.0, 0.0)
        # events (insertion, sleep, wake, retirement) and positions changed between steps; the per-step check
        # is after the drift, before the forces (after_drift)
        if self.pairs.dirty or neighbours.displacement_since(self.idx, s.pos, self.pairs.pos_build, self.geom,
                                                           self.periodic) > 0.5 * self.skin:
            self.pairs.rebuild()
        if getattr(self.integrator, "variable_step", False):  # e.g. adaptive_free_flight picks its step
            disp, h = self.integrator.advance(self, self._dt, t_limit)
        else:
            disp, h = self.integrator.step(self, self._dt), self._dt
        self.particle_steps += self.idx.size
        self.t += h
        self.steps += 1
        self._commit_models()
        for b in self.boundaries:
            b.advance(h)
        if self.sleeping:
            self.sleepers.sleep_and_wake()
        return disp

    def fix_particles(self, ids):
        """Hold particles *ids* in place for good (a rough base, a structure): they stay contact partners
        but are never integrated nor woken."""
        ids = np.asarray(ids, np.int64)
        self._fixed[ids] = True
        s = self.state
        s.awake[ids] = False
        s.vel[ids] = 0.0
        s.omega[ids] = 0.0
        s.vel_prev[ids] = 0.0
        s.omega_prev[ids] = 0.0
        self.pairs.invalidate()
        self._refresh_idx()

    def run(self, duration: float):
        """Advance by *duration* seconds (rounded up to whole steps; a variable-step integrator lands on it)."""
        if not getattr(self.integrator, "variable_step", False):
            return self.step(int(math.ceil(duration / self._dt - 1e-9)))
        t_end = self.t + float(duration)
        disp = (0.0, 0.0)
        while self.t < t_end - 1e-12 * max(1.0, abs(t_end)):
            disp = self._one_step(t_end)
        return disp

    def run_to_equilibrium(self, e_tol: float, criterion: str = "max", *, max_steps: int = 10_000_000,
                           consecutive: int | None = None) -> EquilibriumResult:
        """Step until the per-step displacement (``max_i |x_i(t+1) - x_i(t)|`` or the sum over i, report
        Step 11) stays below *e_tol* (m) for *consecutive* steps (default: 0.05 s worth and at least 10),
        which guards against a momentary rest at a trajectory apex."""
        if criterion not in ("max", "sum"):
            raise InputError(f"equilibrium criterion must be 'max' or 'sum', got {criterion!r}")
        if not e_tol > 0:
            raise InputError(f"E_TOL={e_tol!r} must be > 0")
        k = 0 if criterion == "max" else 1
        if consecutive is None:
            consecutive = max(10, int(math.ceil(0.05 / self._dt)))
        ok = 0
        ps0, st0 = self.particle_steps, self.steps
        disp = (math.inf, math.inf)
        left = int(max_steps)
        while left > 0:
            done = 0
            run = steploop.runner(self) if self.compiled else None
            if run is not None:  # many steps in one compiled call
                done, disp, ok = run(self, left, e_tol, k, consecutive, ok)
            if done == 0:
                disp = self._one_step()
                ok = ok + 1 if disp[k] < e_tol else 0
                done = 1
            left -= done
            if ok >= consecutive:
                return EquilibriumResult(True, self.steps - st0, self.t, disp[k], self.particle_steps - ps0)
        return EquilibriumResult(False, self.steps - st0, self.t, disp[k], self.particle_steps - ps0)

    # ------------------------------------------------------------------ neighbour list and sleeping
    def after_drift(self, relist: bool = True):
        """Wrap periodic coordinates, retire particles that left the domain, refuse NaN; then, before the
        forces at these positions, rebuild the pair list if some awake particle moved more than ``skin/2``
        since the build (:meth:`.pairlist.PairList.relist_after_drift`; *relist* False: the caller does it,
        with the interval's reach, once it knows the velocities the contact law will use)."""
        s = self.state
        nleft, bad = neighbours.wrap_and_check(self.idx, s.pos, s.vel, s.omega, self.geom, self.periodic, self._box,
                                             self._use_box, s.active, s.awake, self._tmp_ids)
        if bad >= 0:
            raise PhysicsError(
                f"particle {bad} has a non-finite position/velocity at t={self.t:.6g} s; the time step "
                f"{self._dt:.3g} s (stable limit {self.dt_limit:.3g} s) or the inputs are unstable")
        if nleft:
            self.left_domain.extend(int(i) for i in self._tmp_ids[:nleft])
            self.idx = self.idx[s.active[self.idx]]
            self.pairs.invalidate()
        if relist:
            self.pairs.relist_after_drift()

    def interval_reach(self, interval) -> float:
        """How far ahead in time (s) the contact law looks with the force *interval* ``(lo, hi)`` in steps:
        ``max(-lo, hi) dt`` for the step-averaged law (it gives a force to a pair apart by less than
        ``max(-lo, hi) dt |v_rel . n|``, :func:`.contact_law.contact_law`), 0 for point values. Times the
        largest speed the law uses, the reach of :meth:`.pairlist.PairList.relist_after_drift`."""
        return max(-(interval[0] * self._dt), interval[1] * self._dt) if self._law == STEP_AVERAGED else 0.0

    def sleep(self, ids) -> np.ndarray:
        """Put particles *ids* to sleep now (e.g. masses that were at rest at the end of the previous
        cycle); returns the ids actually put to sleep (active, not fixed).

        Like the automatic transition (docs/theory.md, *DEM contact* sleeping): velocities and spins are zeroed (also the
        previous-step ones the report scheme uses); they are no longer integrated but remain contact
        partners. The force models' force on each is evaluated now, at rest, and kept as the reference of
        the wake-by-force check, so they wake only on a real change of that force (more than
        ``wake_force_fraction`` of the weight), when a moving particle (contact-point speed above
        ``wake_velocity``) or a moving boundary touches them. The neighbour list is rebuilt at the next
        step, parking the (shear, rolling) histories of pairs whose partners now both sleep.
        """
        return self.sleepers.sleep(ids)

    def wake_all(self):
        """Wake every sleeping particle that is not fixed (the neighbour list is rebuilt at the next step)."""
        self.sleepers.wake_all()

    # ------------------------------------------------------------------ checkpoints (:mod:`.checkpoint`)
    def save_state(self) -> dict[str, np.ndarray]:
        """Everything a bit-identical continuation needs, as a flat dict of numpy arrays (copies;
        :func:`.checkpoint.save_state`). Save with e.g. ``np.savez(path, **sim.save_state())``."""
        return checkpoint.save_state(self)

    @classmethod
    def from_state(cls, data, *, boundaries=(), models=(), **kwargs) -> "DemSimulation":
        """A simulation continuing exactly from ``data`` (:meth:`save_state`, or an ``np.load`` of it;
        :func:`.checkpoint.from_state`: *boundaries* the same kinds in the same order, *models* and the other
        keyword arguments those of the constructor)."""
        return checkpoint.from_state(cls, data, boundaries=boundaries, models=models, **kwargs)

    def memory_bytes(self) -> int:
        """Bytes held by the particle state, work arrays, neighbour list and histories
        (:func:`.checkpoint.memory_bytes`)."""
        return checkpoint.memory_bytes(self)


def _accepts_idx(method) -> bool:
    """Whether a force model's method takes the ``idx=`` keyword (evaluate given rows only)."""
    try:
        return "idx" in inspect.signature(method).parameters
    except (TypeError, ValueError):
        return False


class _StateView:
    """The state with substituted kinematics (integrators may pass predicted velocities)."""

    __slots__ = ("pos", "vel", "omega", "vel_h", "omega_h", "radius", "mass", "inertia", "_props")

    def __init__(self, s, pos, vel, omega, vel_h=None, omega_h=None):
        self.pos, self.vel, self.omega, self.radius, self._props = pos, vel, omega, s.radius, s._props
        self.vel_h = vel if vel_h is None else vel_h
        self.omega_h = omega if omega_h is None else omega_h
        self.mass, self.inertia = s.mass, s.inertia
