"""The DEM driver: particles, boundaries, force models, neighbour lists, sleeping (SPEC §5, §7 steps 4–9).

>>> rock = Material(density=2650, kn=1e7, friction=0.5, c_cn=4e4)
>>> sim = DemSimulation(boundaries=[Plane((0, 0, 0), (0, 0, 1), rock)])
>>> _ = sim.add_particles([[0.0, 0.0, 2.0]], radius=0.5, material=rock)
>>> result = sim.run_to_equilibrium(e_tol=1e-6)
>>> result.converged
True

Neighbour list: pairs closer than ``skin`` are listed (hashed cell grid, :mod:`.contacts`) and
reused until some awake particle has moved more than ``skin/2`` or particles fell asleep / woke /
were inserted. Each pair keeps its shear history across steps and across rebuilds; when both
partners sleep the history is parked in a sorted "frozen" store and restored when one wakes.

Sleeping: an awake particle whose speed and ``r |w|`` stay below ``sleep_velocity`` for
``sleep_steps`` consecutive steps is put to sleep (transitions are applied every ``sleep_check``
steps, so that one O(N) re-binning serves a batch of new sleepers) (not integrated, velocity zero, still a contact
partner). It is woken when a moving particle (contact-point speed above ``wake_velocity``, default
10 ``sleep_velocity``) touches it, when a moving boundary touches it, or when the force models' force on it changes by more than
``wake_force_fraction`` of its weight. Per-step work is proportional to the awake particles and their
pairs; the O(N) work (re-binning sleeping particles, merging parked histories) happens only when
particles fall asleep or wake. :meth:`DemSimulation.sleep` puts given particles to sleep at once (the
cycle's masses that rested at the end of the previous cycle).

Each listed pair keeps a shear history (``_hist``, m) and a rolling-moment history (``_rhist``, N m,
for ``rolling_friction`` > 0, :func:`.contact_law.rolling_law`); both are parked and restored together.
:meth:`DemSimulation.save_state` / :meth:`DemSimulation.from_state` round-trip everything for a
bit-identical continuation.
"""
from __future__ import annotations

import inspect
import math
from dataclasses import dataclass, fields

import numpy as np

from ..errors import InputError, PhysicsError
from . import contacts, memory, neighbours, steploop
from .boundaries import Boundary, Plane
from .contact_laws import resolve as resolve_contact_law
from .forces import G, ForceModel, Gravity, add_global_damping, zero_rows
from .integrators import integrators
from .state import Material, ParticleState
from .timestep import SAFETY, check_dt, stable_dt

_EMPTY_I = np.zeros(0, np.int64)
_EMPTY_GRID = (np.zeros(2, np.int64), _EMPTY_I, _EMPTY_I, 0)


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
    (:mod:`.contact_laws`: ``window_averaged``, the default, or LAMMPS' ``hooke_history``).
    """

    def __init__(self, state: ParticleState | None = None, *, boundaries=(), models=(), gravity=(0.0, 0.0, -G),
                 integrator="predicted_verlet", dt: float | None = None, periodic_x=None, periodic_y=None,
                 domain=None, skin: float | None = None, cell_size: float | None = None, sleeping: bool = True,
                 sleep_velocity: float = 1e-3, wake_velocity: float | None = None, sleep_steps: int = 100,
                 sleep_check: int = 25,
                 wake_force_fraction: float = 0.05, static_models: bool = False,
                 plane_2d: bool = False, contact_law="window_averaged"):
        self.state = state if state is not None else ParticleState.empty()
        self.boundaries: list[Boundary] = list(boundaries)
        self.models: list[ForceModel] = list(models)
        for m in self.models:
            if not isinstance(m, ForceModel):
                raise InputError(f"force model {m!r} lacks added_mass/accumulate (ForceModel protocol)")
        self.gravity = Gravity(gravity)
        self.integrator = integrators.get(integrator)() if isinstance(integrator, str) else integrator
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
        # static_models: the force models do not change in time (a frozen flow field, SPEC §7 step 3), so a
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
        for name in ("force", "torque", "_pos_build", "_fm", "_tm", "_fm_sleep"):
            g(name, (n, 3))
        g("_sleep_count", (n,), np.int64)
        g("_wake_flag", (n,), bool)
        g("_fixed", (n,), bool)
        g("_wake_ids", (n,), np.int64)
        g("_tmp_ids", (n,), np.int64)
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
        self._dirty = True
        self._sleep_grid_dirty = True

    def add_particles(self, pos, radius, material: Material | None = None, vel=None, omega=None) -> np.ndarray:
        """Insert spheres (SI); returns their indices. They start awake."""
        idx = self.state.add(pos, radius, material, vel=vel, omega=omega)
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
        self._dirty = True
        self._sleep_grid_dirty = True
        self._refresh_idx()
        self._commit_models()
        if not hasattr(self, "_pa"):
            self._pa = self._pb = _EMPTY_I
            self._hist = np.zeros((0, 3))
            self._rhist = np.zeros((0, 3))
            self._touch = np.zeros(0, bool)
            self._frozen_keys = np.zeros(0, np.int64)
            self._frozen_hist = np.zeros((0, 6))  # parked (shear, rolling) histories

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

    def contact_forces(self, pos, vel, omega, force, torque, window=(0.0, 0.0), vel_h=None, omega_h=None):
        """Zero the awake rows of force/torque, then add all contact forces (particles and boundaries).

        Called once per step: it advances the shear histories by one step. *window* ``(lo, hi)`` in
        steps: the interval around the evaluation time over which the integrator applies these forces
        (``(-1/2, 1/2)`` for kick–drift–kick Verlet); contact forces are averaged over it so that contact
        onset and release inside a step are resolved (:func:`.contact_law.contact_law`). ``(0, 0)``: point values.
        *vel*, *omega*: velocities at the evaluation time (dashpots); *vel_h*, *omega_h* (default: the same):
        the velocities that moved the positions over the step, which advance the shear histories.
        """
        s = self.state
        zero_rows(self.idx, force, torque)
        self._n_wake[0] = 0
        lo, hi = window[0] * self._dt, window[1] * self._dt
        split = vel_h is not None and vel_h is not vel
        vel_h = vel if vel_h is None else vel_h
        omega_h = omega if omega_h is None else omega_h
        n = contacts.pair_forces_window(self._pa, self._pb, self._hist, self._rhist, self._touch, pos, vel, omega,
                                        vel_h, omega_h, split, s.radius, s.mass, s.inertia, s._props, s.awake,
                                        s.active, self.geom, self.periodic, self._dt, self.wake_velocity, force,
                                        torque, self._wake_flag, self._wake_ids, self._n_wake, lo, hi, self._law)
        view = _StateView(s, pos, vel, omega, vel_h, omega_h)
        for b in self.boundaries:
            n += b.forces(self.idx, view, self._dt, force, torque, lo, hi, self._law)
        self.n_contacts = n

    def refresh_forces(self):
        """Evaluate force/torque at the current state without advancing shear histories (Verlet's first
        half kick needs F(t) of inserted or woken particles)."""
        s = self.state
        saved = [(self._hist.copy(), self._rhist.copy())] + [(b.hist.copy(), b.rhist.copy()) for b in self.boundaries]
        dt, self._dt = self._dt, 0.0
        try:
            self.contact_forces(s.pos, s.vel, s.omega, self.force, self.torque)
        finally:
            self._dt = dt
            self._hist[:], self._rhist[:] = saved[0]
            for b, (h, rh) in zip(self.boundaries, saved[1:]):
                b.hist[:] = h
                b.rhist[:] = rh
        self._n_wake[0] = 0
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

    def after_drift(self):
        """Wrap periodic coordinates, retire particles that left the domain, refuse NaN."""
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
            self._dirty = True
            self._sleep_grid_dirty = True

    # ------------------------------------------------------------------ neighbour list
    def relist_inline(self) -> bool:
        """Whether the pair list can be rebuilt by :func:`.neighbours.rebuild` (also inside the compiled
        many-steps loops): the sleeping grid is current (no sleep, wake or retirement since it was built),
        or there is no sleeping particle and no parked history (then the grid is rebuilt empty), so no
        history has to be parked or restored."""
        s = self.state
        if not self._sleep_grid_dirty and hasattr(self, "_sgrid"):
            return True
        return bool(self.single_bin and self._frozen_keys.size == 0 and not (s.active & ~s.awake).any())

    def _relist(self):
        """The rebuild of :meth:`relist_inline`: the same compiled :func:`.neighbours.rebuild` as the
        many-steps loops, so the pair list is the same on both paths."""
        s = self.state
        if self._sleep_grid_dirty:
            self._sgrid = self._grid(_EMPTY_I)
        bufs = getattr(self, "_pbufs", None) or neighbours.empty_buffers()
        self._pa, self._pb, self._hist, self._rhist, self._touch, self._pbufs = neighbours.rebuild(
            self.idx, s.pos, s.radius, 0.5 * self.skin, self.geom, self.periodic, self.ncell, bool(self.single_bin),
            self._sgrid, self._pa, self._pb, self._hist, self._rhist, self._pos_build, bufs)
        self._dirty = False
        self._sleep_grid_dirty = False

    def _rebuild(self):
        """Rebuild the pair list: between events ``_relist``; after a sleep, wake or retirement (the
        sleeping grid is out of date) re-bin the sleepers, restore parked histories of pairs found again
        and park those of pairs whose partners now both sleep."""
        if self.relist_inline():
            return self._relist()
        s = self.state
        sleep_idx = np.flatnonzero(~s.awake & s.active).astype(np.int64)
        self._sgrid = self._grid(sleep_idx)
        self._agrid = self._grid(self.idx)
        pa, pb = self._find(self.idx, self._agrid, self._sgrid)
        n = pa.size
        keys = (pa[:n] << 32) | pb[:n]
        if self.single_bin and self._sgrid[1].size == 0:
            keys = np.sort(keys)  # one cell per particle, one grid: each pair is found once
        else:  # a woken particle may still sit in the (stale) sleeping grid as well as in the awake one
            keys = np.unique(keys)
        n = keys.size
        new_hist = np.zeros((n, 6))
        old_keys = (self._pa << 32) | self._pb
        old_hist = np.concatenate([self._hist, self._rhist], axis=1)  # (shear, rolling) per pair
        if self._frozen_keys.size:
            src_keys = np.concatenate([old_keys, self._frozen_keys])
            src_hist = np.concatenate([old_hist, self._frozen_hist])
            o = np.argsort(src_keys, kind="stable")
            src_keys, src_hist = src_keys[o], src_hist[o]
        else:
            src_keys, src_hist = old_keys, old_hist  # old list is sorted
        if src_keys.size and n:
            loc = np.minimum(np.searchsorted(src_keys, keys), src_keys.size - 1)
            hit = src_keys[loc] == keys
            new_hist[hit] = src_hist[loc[hit]]
        if src_keys.size:  # park the histories of pairs that are now between two sleeping particles
            in_new = np.zeros(src_keys.size, bool)
            if n:
                loc2 = np.minimum(np.searchsorted(keys, src_keys), max(n - 1, 0))
                in_new = keys[loc2] == src_keys
            a, b = src_keys >> 32, src_keys & 0xFFFFFFFF
            park = (~in_new & ~s.awake[a] & ~s.awake[b] & s.active[a] & s.active[b]
                    & np.any(src_hist != 0.0, axis=1))
            self._frozen_keys, self._frozen_hist = src_keys[park], src_hist[park]
        self._pa, self._pb = keys >> 32, keys & 0xFFFFFFFF
        self._hist = np.ascontiguousarray(new_hist[:, :3])
        self._rhist = np.ascontiguousarray(new_hist[:, 3:])
        self._touch = np.zeros(n, bool)
        self._pos_build[self.idx] = s.pos[self.idx]
        self._dirty = False
        self._sleep_grid_dirty = False

    def _on_sleep(self):
        """New sleepers: re-bin the sleeping particles (O(N_sleep), once per sleep_check batch) and park
        the histories of listed pairs whose partners now both sleep; no new pair search is needed."""
        if self._dirty or self._sleep_grid_dirty or not hasattr(self, "_sgrid"):
            self._dirty = True
            self._sleep_grid_dirty = True
            return
        s = self.state
        self._sgrid = self._grid(np.flatnonzero(~s.awake & s.active).astype(np.int64))
        both = ~s.awake[self._pa] & ~s.awake[self._pb]
        if not both.any():
            return
        pair_hist = np.concatenate([self._hist, self._rhist], axis=1)
        park = both & np.any(pair_hist != 0.0, axis=1)
        if park.any():
            keys = (self._pa[park] << 32) | self._pb[park]
            at = np.searchsorted(self._frozen_keys, keys)
            self._frozen_keys = np.insert(self._frozen_keys, at, keys)
            self._frozen_hist = np.insert(self._frozen_hist, at, pair_hist[park], axis=0)
        keep = ~both
        self._pa, self._pb = self._pa[keep], self._pb[keep]
        self._hist, self._rhist = self._hist[keep], self._rhist[keep]
        self._touch = self._touch[keep]

    def _find(self, search, grid_a, grid_s):
        s = self.state
        cap = max(64, 16 * search.size)
        while True:
            pa = np.empty(cap, np.int64)
            pb = np.empty(cap, np.int64)
            n = contacts.find_pairs(search, s.pos, s.radius, 0.5 * self.skin, self.geom, self.periodic, self.ncell,
                                    *grid_a, *grid_s, self.single_bin, pa, pb)
            if n <= cap:
                return pa[:n], pb[:n]
            cap = int(n * 1.2) + 16

    def _attach_woken(self, ids):
        """Add the pairs of freshly woken particles with sleeping ones (their pairs with awake particles
        are listed already), restoring parked histories: O(woken + awake pairs), no O(N) rebuild."""
        if self._dirty or self._sleep_grid_dirty or not hasattr(self, "_sgrid"):
            return  # a full rebuild is due anyway
        pa, pb = self._find(ids, _EMPTY_GRID, self._sgrid)
        keys = np.unique((pa << 32) | pb)
        old = (self._pa << 32) | self._pb
        if old.size and keys.size:
            loc = np.minimum(np.searchsorted(old, keys), old.size - 1)
            keys = keys[old[loc] != keys]
        if keys.size == 0:
            return
        hist = np.zeros((keys.size, 6))
        fk = self._frozen_keys
        if fk.size:
            loc = np.minimum(np.searchsorted(fk, keys), fk.size - 1)
            hit = fk[loc] == keys
            hist[hit] = self._frozen_hist[loc[hit]]
            keep = np.ones(fk.size, bool)
            keep[loc[hit]] = False
            self._frozen_keys, self._frozen_hist = fk[keep], self._frozen_hist[keep]
        allk = np.concatenate([old, keys])
        order = np.argsort(allk, kind="stable")
        merged = np.concatenate([np.concatenate([self._hist, self._rhist], axis=1), hist])[order]
        self._hist = np.ascontiguousarray(merged[:, :3])
        self._rhist = np.ascontiguousarray(merged[:, 3:])
        allk = allk[order]
        self._pa, self._pb = allk >> 32, allk & 0xFFFFFFFF
        self._touch = np.zeros(allk.size, bool)

    def _grid(self, idx):
        est = max(1024, 16 * idx.size)
        bits = int(math.ceil(math.log2(est)))
        start, ep, ec = contacts.build_grid(idx, self.state.pos, self.state.radius, 0.5 * self.skin, self.geom,
                                            self.periodic, self.ncell, bits, self.single_bin)
        return start, ep, ec, bits

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

    _n_wake = np.zeros(1, np.int64)

    def _one_step(self, t_limit: float = math.inf):
        s = self.state
        self._n_wake = np.zeros(1, np.int64)
        self._wake_from_boundaries()
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
            self._wake_by_force()
            self._models_checked = True
        if self.idx.size == 0:
            self.t += self._dt
            self.steps += 1
            for b in self.boundaries:
                b.advance(self._dt)
            return (0.0, 0.0)
        if self._dirty or neighbours.displacement_since(self.idx, s.pos, self._pos_build, self.geom,
                                                      self.periodic) > 0.5 * self.skin:
            self._rebuild()
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
            self._sleep_and_wake()
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
        self._sleep_grid_dirty = True
        self._dirty = True
        self._refresh_idx()

    def sleep(self, ids) -> np.ndarray:
        """Put particles *ids* to sleep now (e.g. masses that were at rest at the end of the previous
        cycle); returns the ids actually put to sleep (active, not fixed).

        Like the automatic transition (SPEC §5 sleeping): velocities and spins are zeroed (also the
        previous-step ones the report scheme uses); they are no longer integrated but remain contact
        partners. The force models' force on each is evaluated now, at rest, and kept as the reference of
        the wake-by-force check, so they wake only on a real change of that force (more than
        ``wake_force_fraction`` of the weight), when a moving particle (contact-point speed above
        ``wake_velocity``) or a moving boundary touches them. The neighbour list is rebuilt at the next
        step, parking the (shear, rolling) histories of pairs whose partners now both sleep.
        """
        s = self.state
        ids = np.unique(np.asarray(ids, np.int64).ravel())
        if ids.size and (ids[0] < 0 or ids[-1] >= s.n):
            raise InputError(f"sleep: particle ids must be in [0, {s.n}), got {ids[0]}..{ids[-1]}")
        ids = ids[s.active[ids] & ~self._fixed[ids]]
        if ids.size == 0:
            return ids
        s.awake[ids] = False
        for a in (s.vel, s.omega, s.vel_prev, s.omega_prev, self.work["v"], self.work["w"]):
            a[ids] = 0.0
        self._sleep_count[ids] = 0
        self._wake_flag[ids] = False
        if self.models:
            fm, tm = np.zeros((s.n, 3)), np.zeros((s.n, 3))
            for m in self.models:
                m.accumulate(s, s.pos, s.vel, s.omega, self.t, fm, tm)
            self._fm_sleep[ids] = fm[ids]
        self._dirty = self._sleep_grid_dirty = True
        self._refresh_idx()
        return ids

    def _wake(self, ids):
        if len(ids) == 0:
            return 0
        s = self.state
        ids = np.asarray(ids, np.int64)
        ids = ids[~self._fixed[ids]]
        if ids.size == 0:
            return 0
        s.awake[ids] = True
        self._wake_flag[ids] = False
        self._sleep_count[ids] = 0
        # a sleeping particle was in equilibrium: its net force (hence a(t) for the Verlet kick) is ~0;
        # refreshing F(t) exactly would cost one contact evaluation per wake event
        self.force[ids] = 0.0
        self.torque[ids] = 0.0
        self.work["fp"][ids] = 0.0  # previous-step force (predicted_verlet's trend): none
        self.work["tp"][ids] = 0.0
        self._pos_build[ids] = s.pos[ids]
        self.idx = np.union1d(self.idx, ids).astype(np.int64)
        self._attach_woken(ids)
        return ids.size

    def _sleep_and_wake(self):
        s = self.state
        changed = False
        nw = int(self._n_wake[0])
        if nw:
            ids = self._wake_ids[:nw].copy()
            self._wake_flag[ids] = False
            self._wake(ids)
        if self.models and not self.static_models:
            self._wake_by_force()
        # transitions to sleep only every sleep_check steps: one O(N) regrid per batch of sleepers
        ns = contacts.sleep_update(self.idx, s.vel, s.omega, s.vel_prev, s.omega_prev, s.radius, self.sleep_velocity,
                                   self.sleep_steps, self._sleep_count, s.awake, self._tmp_ids,
                                   self.steps % self.sleep_check == 0)
        if ns:
            self._after_sleep(ns)

    def _after_sleep(self, ns):
        """Bookkeeping of the *ns* particles that just fell asleep (listed in ``_tmp_ids``)."""
        s = self.state
        ids = self._tmp_ids[:ns]
        self._fm_sleep[ids] = self._fm[ids]
        self.idx = self.idx[s.awake[self.idx]]
        self._on_sleep()

    def _wake_by_force(self):
        """Wake sleepers whose force-model force (last evaluated into ``_fm``) moved away from the value
        recorded when they fell asleep by more than ``wake_force_fraction`` of their weight."""
        s = self.state
        asleep = np.flatnonzero(~s.awake & s.active)
        if asleep.size:
            dF = np.linalg.norm(self._fm[asleep] - self._fm_sleep[asleep], axis=1)
            woke = asleep[dF > self.wake_force_fraction * s.mass[asleep] * np.linalg.norm(self.gravity.g)]
            self._wake(woke)

    def _wake_from_boundaries(self):
        s = self.state
        for b in self.boundaries:
            if b.moving and isinstance(b, Plane):
                asleep = np.flatnonzero(~s.awake & s.active)
                if asleep.size:
                    gap = (s.pos[asleep] - b.point) @ b.normal - s.radius[asleep]
                    touching = asleep[gap < self.skin]
                    self._wake(touching)

    def wake_all(self):
        s = self.state
        self._dirty = self._sleep_grid_dirty = True
        self._wake(np.flatnonzero(~s.awake & s.active & ~self._fixed))

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

    # ------------------------------------------------------------------ save / restore
    _SAVED_ARRAYS = ("force", "torque", "_pos_build", "_fm", "_tm", "_fm_sleep", "_sleep_count", "_wake_flag", "_fixed",
                     "_pa", "_pb", "_hist", "_rhist", "_touch", "_frozen_keys", "_frozen_hist", "geom", "ncell",
                     "periodic", "_box")
    _SAVED_SCALARS = {"t": float, "steps": int, "particle_steps": int, "n_contacts": int, "_dt": float,
                      "dt_limit": float, "skin": float, "single_bin": bool, "_dirty": bool,
                      "_sleep_grid_dirty": bool, "forces_stale": bool, "_use_box": bool}

    def save_state(self) -> dict[str, np.ndarray]:
        """Everything a bit-identical continuation needs, as a flat dict of numpy arrays (copies):
        the particle arrays (``state.*``), forces of the last step, integrator work arrays, sleep
        counters and wake references, the neighbour list with its shear / rolling histories (live and
        parked), the sleeping-particle grid, the boundaries' histories and motion (``boundary<k>.*``),
        ``t``, ``steps``, ``dt``, and the memory of the integrator and of force models with one
        (``integrator.*``, ``model<k>.*``, :mod:`.memory`). Force models themselves are not saved (they are
        passed again to :meth:`from_state`, which restores their memory into them).
        Save with e.g. ``np.savez(path, **sim.save_state())``.
        """
        out: dict[str, np.ndarray] = {}
        for f in fields(self.state):
            out["state." + f.name] = np.array(getattr(self.state, f.name), copy=True)
        for name in self._SAVED_ARRAYS:
            out["sim." + name] = np.array(getattr(self, name), copy=True)
        for name in self._SAVED_SCALARS:
            out["sim." + name] = np.array(getattr(self, name))
        for k, a in self.work.items():
            out["work." + k] = a.copy()
        out["sim.left_domain"] = np.asarray(self.left_domain, np.int64)
        grid = getattr(self, "_sgrid", None)
        if grid is not None:
            for name, a in zip(("start", "ent_p", "ent_c"), grid[:3]):
                out["sgrid." + name] = a.copy()
            out["sgrid.bits"] = np.array(grid[3])
        out["n_boundaries"] = np.array(len(self.boundaries))
        for k, b in enumerate(self.boundaries):
            out[f"boundary{k}.hist"] = b.hist.copy()
            out[f"boundary{k}.rhist"] = b.rhist.copy()
            if isinstance(b, Plane):
                for name in ("point", "velocity", "reaction"):
                    out[f"boundary{k}.{name}"] = getattr(b, name).copy()
        memory.save(self.integrator, "integrator.", out)
        for k, m in enumerate(self.models):
            memory.save(m, f"model{k}.", out)
        return out

    @classmethod
    def from_state(cls, data, *, boundaries=(), models=(), **kwargs) -> "DemSimulation":
        """A simulation continuing exactly from ``data`` (:meth:`save_state`, or an ``np.load`` of it).

        *boundaries* must be the same kinds in the same order as when saved (their histories and plane
        motion are restored into them); *models* and the other keyword arguments are those of the
        constructor and should match the saved run (the time step and cell geometry are restored from
        *data* regardless). The integrator and the models get their saved memory back; one whose memory
        does not match the saved one (e.g. the Basset force on in one, off in the other) is an InputError.
        """
        try:
            state = ParticleState(**{f.name: np.array(data["state." + f.name]) for f in fields(ParticleState)})
            nb = int(data["n_boundaries"])
        except KeyError as e:
            raise InputError(f"DEM state lacks entry {e.args[0]!r} (not written by save_state?)") from None
        boundaries = list(boundaries)
        if nb != len(boundaries):
            raise InputError(f"DEM state was saved with {nb} boundaries, {len(boundaries)} given")
        sim = cls(state, boundaries=boundaries, models=models, **kwargs)
        for name in cls._SAVED_ARRAYS:
            setattr(sim, name, np.array(data["sim." + name], copy=True))
        for name, typ in cls._SAVED_SCALARS.items():
            setattr(sim, name, typ(data["sim." + name][()]))
        for k in sim.work:
            if "work." + k in data:
                sim.work[k] = np.array(data["work." + k], copy=True)
        for k, f in (("fp", "force"), ("tp", "torque")):  # saved before the force trend was kept: none
            if "work." + k not in data:
                sim.work[k] = np.array(data["sim." + f], copy=True)
        sim.left_domain = [int(i) for i in data["sim.left_domain"]]
        if "sgrid.start" in data:
            sim._sgrid = tuple(np.array(data["sgrid." + n], copy=True) for n in ("start", "ent_p", "ent_c")) + (
                int(data["sgrid.bits"][()]),)
        for k, b in enumerate(boundaries):
            if isinstance(b, Plane) != (f"boundary{k}.point" in data):
                raise InputError(f"boundary {k} is not of the kind saved")
            b.hist = np.array(data[f"boundary{k}.hist"], copy=True)
            b.rhist = np.array(data[f"boundary{k}.rhist"], copy=True)
            if isinstance(b, Plane):
                for name in ("point", "velocity", "reaction"):
                    setattr(b, name, np.array(data[f"boundary{k}.{name}"], copy=True))
        memory.restore(sim.integrator, "integrator.", data, "integrator")
        for k, m in enumerate(sim.models):
            memory.restore(m, f"model{k}.", data, f"force model {k}")
        beyond = [k for k in data if k.startswith("model") and not k.startswith(tuple(f"model{j}." for j in
                                                                                     range(len(sim.models))))]
        if beyond:
            raise InputError(f"DEM state holds {', '.join(sorted(beyond))} of force models beyond the "
                             f"{len(sim.models)} given")
        sim._inv_m = 1.0 / sim.state.mass
        sim._inv_i = 1.0 / sim.state.inertia
        sim._refresh_idx()
        return sim

    def memory_bytes(self) -> int:
        """Bytes held by the particle state, work arrays, neighbour list and histories."""
        total = self.state.nbytes() + sum(a.nbytes for a in self.work.values())
        for name in ("force", "torque", "_pos_build", "_fm", "_tm", "_fm_sleep", "_sleep_count", "_wake_flag", "_fixed",
                     "_wake_ids", "_tmp_ids", "_pa", "_pb", "_hist", "_rhist", "_touch", "_frozen_keys", "_frozen_hist"):
            total += getattr(self, name).nbytes
        for g in (getattr(self, "_agrid", None), getattr(self, "_sgrid", None)):
            if g is not None:
                total += sum(a.nbytes for a in g[:3])
        total += sum(b.hist.nbytes + b.rhist.nbytes for b in self.boundaries)
        bufs = getattr(self, "_pbufs", ())  # the list's capacity: the live list may be a view into it
        total += sum(a.nbytes for a in bufs)
        total -= sum(getattr(self, name).nbytes for name in ("_pa", "_pb", "_hist", "_rhist", "_touch")
                     if any(np.may_share_memory(getattr(self, name), a) for a in bufs))
        return total


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
