"""Fluid forces on the DEM particles: :class:`FluidForces`, a DEM ``ForceModel`` (docs/theory.md, *Fluid forces on a mass*, a ForceModel of breachflow.dem.forces).

Per particle, with ``V_sub`` the submerged volume (spherical cap while straddling the free surface
``z_bed + h``) and ``phi = V_sub / V`` (see :mod:`breachflow.fluid.kernels` for the crossing rule):

* buoyancy ``f_B = (rho_W V_sub + rho_A (V - V_sub)) g e_z`` (gravity ``rho_S V g`` is the DEM's);
* drag ``f_D = -1/2 A [phi rho_W C_D(R_W) |r_W| r_W + (1 - phi) rho_A C_D(R_A) |r_A| r_A]``,
  ``r_W = v - (u, v, 0)`` relative to the sampled water velocity, ``r_A = v - wind``, ``R = |r| D / nu``;
  ``C_D`` the model's drag law, or a particle's own drag coefficient where it has one (the state's
  ``drag_coefficient``, e.g. a closure material's shape drag; also in the gridpoint torque), so that
  masses of different materials in one simulation each feel their own;
* apparent mass: :meth:`FluidForces.added_mass` returns ``xi (rho_W V_sub + rho_A (V - V_sub))``, which the
  integrators add to ``m``; :meth:`FluidForces.accumulate` adds the convective part ``xi rho_W V_sub (u(x_pred) - u(x)) / dt``
  with ``x_pred = x + v dt`` in the frozen field (Fig 4.3 Step 7H);
* fluid torque from the gridpoints in the particle's neighbourhood (Step 7E, Fig 4.4);
* the water velocity at a particle is the depth-averaged one times the vertical profile factor at the
  particle's centre height (``velocity_profile``: ``log``, the default, :data:`~breachflow.fluid.profile.DEFAULT_PROFILE`,
  also that of ``[fluid] velocity_profile``; ``uniform``, the report's setting; ``power``;
  :mod:`breachflow.fluid.profile`; the drag, the Basset history and the convective apparent-mass term use
  it; buoyancy and apparent mass do not depend on it, and the gridpoint torque still uses the
  depth-averaged gridpoint velocities);
* optional (``basset=True``) Basset history force ``-phi 6 a^2 sqrt(pi rho_W mu_W) int r_W' / sqrt(t - tau)``
  (eq 3.13, :mod:`breachflow.fluid.basset`); the history advances through :meth:`FluidForces.commit`, which
  the DEM and the free-flight integrators call once per accepted step, and is saved with the DEM state
  (:meth:`FluidForces.state_arrays`).

Terms that are zero are skipped per call (decided on whole arrays, not in the hot loop): no convective
term or grid torque in a uniform field (the spin torque of a uniform field uses a virtual lattice and is
skipped when no particle spins), nothing water-related when every particle is in the air, no air terms
when ``air=None``.

Sleeping particles of the DEM still get their (steady) fluid force, evaluated at rest at ``state.pos``:
the DEM wakes a sleeper when the force models' force on it changes.

On a (non-uniform) grid snapshot without the Basset term, :meth:`FluidForces.accumulate` and
:meth:`FluidForces.added_mass` run as one compiled call each, with any velocity profile
(:mod:`breachflow.fluid.compiled`: the field sampled and the profile factor applied once per particle
inside the kernel); ``compiled=False`` keeps the step-by-step path, which gives the same forces to
round-off.

Particles outside the hydrodynamic field: ``outside="error"`` (default) raises
:class:`~breachflow.errors.PhysicsError` naming the particle; ``outside="air"`` treats them as in air.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError, PhysicsError
from . import kernels as K
from .basset import BassetHistory, basset_coefficient
from ..field.sampling import SAMPLING_METHODS
from .drag import DRAG_LAWS, DragLaw
from .field import as_field
from . import nearbed as NB
from .profile import factors as profile_factors_np
from .profile import DEFAULT_PROFILE, profile_code, roughness_from_manning

#: standard gravity (m/s^2); the DEM's ``breachflow.dem.forces.G`` is the same value
G = 9.80665


@dataclass(frozen=True)
class Fluid:
    """A Newtonian fluid: density ``rho`` (kg/m^3), kinematic viscosity ``nu`` (m^2/s)."""

    rho: float
    nu: float

    def __post_init__(self):
        if not (np.isfinite(self.rho) and self.rho > 0 and np.isfinite(self.nu) and self.nu > 0):
            raise InputError(f"fluid: density and kinematic viscosity must be finite and > 0, got {self}")

    @property
    def mu(self) -> float:
        """Dynamic viscosity ``rho nu`` (Pa s)."""
        return self.rho * self.nu


#: Water at about 20 °C (docs/validation.md, *Settling spheres* settling experiments).
WATER = Fluid(rho=1000.0, nu=1.0e-6)
#: Air as used by the report's program (docs/theory.md, *Fluid forces on a mass*).
AIR = Fluid(rho=1.23, nu=1.46e-5)


class FluidForces:
    """The fluid's forces and torques on spheres; implements the DEM ``ForceModel`` protocol.

    Parameters
    ----------
    field
        ``None`` (air only), a number (still water with its surface at that elevation, m),
        :class:`~breachflow.fluid.field.UniformWater`, a snapshot Dataset or a ``FieldSampler``.
    drag_law
        Name in the ``breachflow.drag_laws`` registry or a :class:`~breachflow.fluid.drag.DragLaw` instance (default ``report``).
    sampling
        ``bilinear`` or ``neighbourhood`` when *field* is a Dataset.
    water, air
        Fluid properties; ``air=None`` means vacuum above the water (no air drag or buoyancy).
    xi
        Apparent-mass coefficient (0.5 for spheres); 0 switches apparent mass off.
    torque
        Fluid torque from the neighbourhood gridpoints (docs/theory.md, *Fluid forces on a mass*); ``False`` to skip.
    time_step
        Horizon ``dt`` of the predicted position for the convective apparent-mass term; ``None`` uses a
        displacement of one eighth of the largest grid spacing (exact for a bilinear field).
    wind
        Air velocity (m/s, 3-vector) above the water.
    outside
        ``"error"`` or ``"air"``, what a particle outside the field sees.
    gravity
        ``g`` (m/s^2) for buoyancy.
    velocity_profile
        ``log`` (default) | ``uniform`` | ``power`` (:mod:`breachflow.fluid.profile`): the water velocity a particle
        feels at its centre height ``z - z_bed`` is ``U * profile_factor(...)``.
    roughness, manning
        Roughness height ``k_s`` (m) of the log law; ``None`` derives it from Manning's *manning*
        (Manning–Strickler, :func:`~breachflow.fluid.profile.roughness_from_manning`).
    near_bed
        The near-bed terms' parameter vector (:func:`breachflow.fluid.nearbed.parameters`: the flow over the
        exposed height, lift, turbulent peaks); None (default) leaves them off.
    basset
        Add the Basset history force (off by default; docs/theory.md, *Fluid forces on a mass*); ``basset_range`` ``(s_min, s_max)`` (s)
        is where its kernel quadrature is accurate (relative ~3e-7).
    compiled
        Use the fused kernels of :mod:`breachflow.fluid.compiled` where they apply (default); ``False``
        evaluates term by term (the reference they are tested against).
    """

    def __init__(self, field=0.0, *, drag_law: str | DragLaw = DRAG_LAWS.default, sampling: str = SAMPLING_METHODS.default,
                 water: Fluid = WATER, air: Fluid | None = AIR, xi: float = 0.5, torque: bool = True,
                 time_step: float | None = None, wind=(0.0, 0.0, 0.0), outside: str = "error",
                 gravity: float = G, torque_points: int = 5, basset: bool = False,
                 basset_range=(1e-8, 1e5), velocity_profile: str = DEFAULT_PROFILE, roughness: float | None = None,
                 manning: float = 0.025, compiled: bool = True, near_bed=None):
        self.velocity_profile = str(velocity_profile)
        self.profile_code = profile_code(self.velocity_profile)
        self.roughness = float(roughness_from_manning(manning) if roughness is None else roughness)
        if not (np.isfinite(self.roughness) and self.roughness > 0):
            raise InputError(f"FluidForces: roughness height must be > 0 m, got {roughness!r} (manning {manning!r})")
        #: the near-bed terms' parameter vector (:mod:`breachflow.fluid.nearbed`; all 0: off, the earlier forces)
        self.bedp = NB.off() if near_bed is None else np.ascontiguousarray(near_bed, dtype=float).reshape(NB.N_PARAMS)
        self.near_bed_on = bool(self.bedp[NB.ON] != 0.0)
        self._lam = None
        self.field = as_field(field, sampling)
        self.drag_law = DRAG_LAWS.create(drag_law)
        self.water = water
        self.air = air
        self.xi = float(xi)
        if not (np.isfinite(self.xi) and self.xi >= 0):
            raise InputError(f"FluidForces: apparent-mass coefficient xi must be >= 0, got {xi!r}")
        self.torque = bool(torque)
        self.time_step = None if time_step is None else float(time_step)
        self.wind = np.asarray(wind, dtype=float).reshape(3)
        if outside not in ("error", "air"):
            raise InputError(f"FluidForces: outside must be 'error' or 'air', got {outside!r}")
        self.outside = outside
        self.gravity = float(gravity)
        self.torque_points = int(torque_points)
        self.basset = BassetHistory(*basset_range) if basset else None
        #: number of :meth:`accumulate` calls (force evaluations), for work–precision measurements
        self.evaluations = 0
        self._fused = self._fused_args() if compiled else None

    def _fused_args(self):
        """Arguments of the fused kernels of :mod:`.compiled` when they apply to this field, else None."""
        from . import compiled as C

        sampler = getattr(self.field, "sampler", None)
        if self.basset is not None or sampler is None or sampler.kind != "grid" or self.field.uniform:
            return None
        if getattr(sampler, "frame", None) is not None:
            # a field sampled from a turned grid (hydro.nested.FramedSampler): only its sample() turns the
            # positions and velocities, the raw grid arrays the fused kernels read stay on the CRS axes
            return None
        method = {"bilinear": C.BILINEAR, "linear": C.BILINEAR, "barycentric": C.BILINEAR,
                  "neighbourhood": C.NEIGHBOURHOOD, "neighborhood": C.NEIGHBOURHOOD}.get(sampler.method)
        if method is None:
            return None
        g = sampler.grid_arrays()
        # with a fallback field (nested local grid in the regional model) the fused kernel stops at a particle
        # outside the grid and the call takes the step-by-step path, which samples the fallback there
        return (method, g.bed, g.depth, g.u, g.v, float(g.x0), float(g.y0), float(g.dx), float(g.dy),
                float(self.field.s_max), self.outside == "air" and getattr(sampler, "fallback", None) is None,
                self.profile_code, self.roughness, self.bedp)

    def _has_fallback(self) -> bool:
        return getattr(getattr(self.field, "sampler", None), "fallback", None) is not None

    def _outside_error(self, pos, k, idx):
        raise PhysicsError(
            f"particle {int(idx[k])} at x={pos[idx[k], 0]:.3f} m, y={pos[idx[k], 1]:.3f} m left the hydrodynamic "
            "field (FluidForces(outside='air') lets it see air there)")

    # -- helpers --------------------------------------------------------------------------------------
    def _indices(self, state):
        act = getattr(state, "active", None)
        return np.arange(state.radius.shape[0]) if act is None else np.flatnonzero(act)

    @staticmethod
    def _kinematics(state, idx, pos, vel, omega):
        """Rows *idx* of the given kinematics; sleeping particles (not integrated, so their rows in an
        integrator's predicted arrays are not meaningful) are taken at rest at ``state.pos``."""
        p, w, om = pos[idx], vel[idx], omega[idx]
        awake = getattr(state, "awake", None)
        if awake is not None:
            asleep = ~awake[idx]
            if asleep.any():
                p[asleep] = state.pos[idx[asleep]]
                w[asleep] = 0.0
                om[asleep] = 0.0
        return np.ascontiguousarray(p), np.ascontiguousarray(w), np.ascontiguousarray(om)

    def _sample(self, pos, radius, idx):
        s = self.field.sample(pos[:, 0], pos[:, 1], radius)
        surface = np.asarray(s.surface, dtype=float)
        bed = np.asarray(s.bed, dtype=float)
        inside = np.asarray(s.inside, dtype=bool)
        u = np.asarray(s.u, dtype=float)
        v = np.asarray(s.v, dtype=float)
        if not inside.all():
            if self.outside == "error":
                k = int(np.flatnonzero(~inside)[0])
                raise PhysicsError(
                    f"particle {int(idx[k])} at x={pos[k, 0]:.3f} m, y={pos[k, 1]:.3f} m left the hydrodynamic "
                    "field (FluidForces(outside='air') lets it see air there)")
            surface = np.where(inside, surface, -np.inf)
            bed = np.where(inside, bed, -np.inf)
            u = np.where(inside, u, 0.0)
            v = np.where(inside, v, 0.0)
        if self.near_bed_on:
            u, v, self._lam = self._near_bed(pos, radius, surface, bed, u, v)
        elif self.profile_code != 0:
            u, v = self._profiled(pos, surface, bed, u, v)
        return surface, bed, u, v, inside

    def _near_bed(self, pos, radius, surface, bed, u, v):
        """``(u, v, lam)``: the near-bed velocity the particles feel and their lift factors
        (:func:`~breachflow.fluid.nearbed.near_bed`)."""
        with np.errstate(invalid="ignore"):  # outside the field: surface = bed = -inf
            depth = np.where(np.isfinite(surface) & np.isfinite(bed), surface - bed, 0.0)
            z = np.where(np.isfinite(bed), pos[:, 2] - bed, 0.0)
        g, lam = NB.factors(self.profile_code, self.roughness, z, depth, radius, self.bedp)
        return u * g, v * g, lam

    def _profiled(self, pos, surface, bed, u, v):
        """``(u, v)`` times the vertical profile factor at the particles' centre heights."""
        with np.errstate(invalid="ignore"):  # outside the field: surface = bed = -inf
            depth = np.where(np.isfinite(surface) & np.isfinite(bed), surface - bed, 0.0)
            z = np.where(np.isfinite(bed), pos[:, 2] - bed, 0.0)
        f = profile_factors_np(self.profile_code, z, depth, self.roughness)
        return u * f, v * f

    def submerged_fraction(self, pos, radius) -> np.ndarray:
        """``V_sub / V`` of spheres at *pos* (N,3) with *radius* (N,)."""
        pos = np.ascontiguousarray(pos, dtype=float)
        radius = np.ascontiguousarray(radius, dtype=float)
        surface, bed, _, _, inside = self._sample(pos, radius, np.arange(len(radius)))
        phi = np.empty(len(radius))
        K.submerged_fractions(pos, radius, surface, bed, inside, phi)
        return phi

    @staticmethod
    def own_coefficients(state):
        """``(drag, lift)`` (N,) each: the particles' own drag and lift coefficients
        (:class:`~breachflow.dem.state.ParticleState` ``drag_coefficient``, ``lift_coefficient``; NaN where a
        particle takes the model's drag law and the lift term's coefficient). A state without them: all NaN."""
        n = state.radius.shape[0]
        out = []
        for name in ("drag_coefficient", "lift_coefficient"):
            a = getattr(state, name, None)
            out.append(np.full(n, np.nan) if a is None or a.shape[0] != n else a)
        return out[0], out[1]

    def apparent_coefficients(self, state) -> np.ndarray:
        """(N,) each particle's apparent-mass coefficient: its own (``ParticleState.added_mass_coefficient``, its
        material's) where set, else the model's ``xi``."""
        n = state.radius.shape[0]
        own = getattr(state, "added_mass_coefficient", None)
        if own is None or own.shape[0] != n:
            return np.full(n, self.xi)
        return np.where(np.isnan(own), self.xi, own)

    def _xi_on(self, state) -> bool:
        """Whether any particle has an apparent mass (the model's ``xi`` > 0 or a particle's own)."""
        own = getattr(state, "added_mass_coefficient", None)
        return self.xi > 0.0 or (own is not None and bool(np.any(own > 0.0)))

    # -- ForceModel protocol --------------------------------------------------------------------------
    def added_mass(self, state, pos=None, idx=None) -> np.ndarray | None:
        """Apparent mass ``xi (rho_W V_sub + rho_A (V - V_sub))`` (kg) per particle at ``state.pos`` (or *pos*),
        ``xi`` each particle's own or the model's (:meth:`apparent_coefficients`); with *idx*, only for the
        particles *idx* (an array of ``len(idx)``)."""
        if not self._xi_on(state):
            return None
        xis = self.apparent_coefficients(state)
        pos = state.pos if pos is None else pos
        rows = self._indices(state) if idx is None else np.asarray(idx)
        m = np.empty(rows.size)
        if rows.size and self._fused is not None:
            from .compiled import grid_added_masses

            rows = np.ascontiguousarray(rows, dtype=np.int64)
            k = grid_added_masses(rows, pos, state.radius, *self._fused, self.water.rho,
                                  0.0 if self.air is None else self.air.rho, xis, m)
            if k >= 0 and not self._has_fallback():
                self._outside_error(pos, k, rows)
        if rows.size and (self._fused is None or k >= 0):
            rad = state.radius[rows]
            phi = self.submerged_fraction(pos[rows], rad)
            K.added_masses(rad, phi, self.water.rho, 0.0 if self.air is None else self.air.rho,
                           np.ascontiguousarray(xis[rows]), m)
        if idx is not None:
            return m
        out = np.zeros(state.radius.shape[0])
        out[rows] = m
        return out

    def accumulate(self, state, pos, vel, omega, t, force, torque, idx=None) -> None:
        """Add buoyancy, drag, convective apparent-mass force and fluid torque at the given kinematic state."""
        self.evaluations += 1
        if idx is None:
            idx = self._indices(state)
        if idx.size == 0:
            return
        if self._fused is not None:
            from .compiled import grid_fluid_forces

            ids = np.ascontiguousarray(idx, dtype=np.int64)
            awake = getattr(state, "awake", None)
            if awake is None:
                awake = np.ones(state.radius.shape[0], bool)
            air = self.air if self.air is not None else self.water
            k = grid_fluid_forces(ids, pos, vel, omega, state.pos, awake, state.radius, *self._fused, self.wind,
                                  self.water.rho, self.water.nu, air.rho, air.nu, self.air is not None, self.gravity,
                                  self.drag_law.law_id, self.drag_law.params, *self.own_coefficients(state),
                                  self.apparent_coefficients(state),
                                  self.time_step or 0.0,
                                  self.torque, force, torque)
            if k < 0:
                return
            if not self._has_fallback():
                self._outside_error(np.where(awake[:, None], pos, state.pos), k, ids)
        p, w, om = self._kinematics(state, idx, pos, vel, omega)
        rad = np.ascontiguousarray(state.radius[idx])
        surface, bed, u, v, inside = self._sample(p, rad, idx)
        phi = np.empty(idx.size)
        K.submerged_fractions(p, rad, surface, bed, inside, phi)
        f = np.zeros((idx.size, 3))
        tq = np.zeros((idx.size, 3))
        law, params = self.drag_law.law_id, self.drag_law.params
        cds, cls = (np.ascontiguousarray(a[idx]) for a in self.own_coefficients(state))
        air = self.air if self.air is not None else self.water
        K.buoyancy_and_drag(p, w, rad, phi, u, v, self.wind, self.water.rho, self.water.nu, air.rho, air.nu,
                            self.gravity, law, params, cds, self.air is not None, f)
        if self.near_bed_on and self.bedp[NB.LIFT] > 0.0:  # lift (fluid/nearbed.py); a particle's own C_L wins
            rx, ry = w[:, 0] - u, w[:, 1] - v
            c_l = np.where(cls >= 0.0, cls, self.bedp[NB.LIFT])
            f[:, 2] += (0.5 * self.water.rho * c_l * np.pi * rad ** 2 * phi
                        * np.maximum(self._lam, 0.0) * (rx * rx + ry * ry))
        wet = phi > 0.0
        if wet.any():
            if self.basset is not None:
                self._basset(idx, w, rad, phi, u, v, t, f)
            if self._xi_on(state) and not self.field.uniform:
                self._convective(p, w, rad, phi, u, v, inside, f,
                                 np.ascontiguousarray(self.apparent_coefficients(state)[idx]))
            if self.torque:
                self._torque(p, w, om, rad, phi, u, v, tq, cds)
        force[idx] += f
        torque[idx] += tq

    def commit(self, state, pos, vel, t) -> None:
        """Record an accepted state at time *t* (the Basset history); nothing to do without ``basset``."""
        if self.basset is None:
            return
        idx = self._indices(state)
        if idx.size == 0:
            return
        p = np.ascontiguousarray(pos[idx])
        _, _, u, v, _ = self._sample(p, state.radius[idx], idx)
        self.basset.commit(idx, self._relative(vel[idx], u, v), t)

    def state_arrays(self) -> dict[str, np.ndarray]:
        """The model's memory for ``DemSimulation.save_state``: the Basset history (``basset.*``) when on."""
        if self.basset is None:
            return {}
        return {"basset." + k: a for k, a in self.basset.state_arrays().items()}

    def restore_state(self, arrays) -> None:
        """Take back :meth:`state_arrays`."""
        if self.basset is not None:
            self.basset.restore_state({k[len("basset."):]: a for k, a in arrays.items() if k.startswith("basset.")})

    # -- optional terms -------------------------------------------------------------------------------
    @staticmethod
    def _relative(w, u, v):
        """Velocity relative to the water ``v - (u, v, 0)`` (the depth-averaged field has no vertical part)."""
        r = np.array(w, dtype=float)
        r[:, 0] -= u
        r[:, 1] -= v
        return r

    def _basset(self, idx, w, rad, phi, u, v, t, f):
        """Basset history force ``-phi 6 a^2 sqrt(pi rho mu) H`` (docs/theory.md, *Fluid forces on a mass*, eq 3.13)."""
        hist = self.basset.integral(idx, self._relative(w, u, v), t)
        f -= (basset_coefficient(rad, self.water.rho, self.water.mu) * phi)[:, None] * hist

    def _convective(self, p, w, rad, phi, u, v, inside, f, xis):
        speed_h = np.hypot(w[:, 0], w[:, 1])
        vmax = float(speed_h.max())
        if vmax == 0.0:
            return
        horizon = self.time_step if self.time_step else 0.125 * max(self.field.s_max, 1e-3) / vmax
        ahead = p + w * horizon
        s1 = self.field.sample(ahead[:, 0], ahead[:, 1], rad)
        ok = np.asarray(s1.inside, bool) & inside
        su, sv = np.asarray(s1.u, float), np.asarray(s1.v, float)
        if self.near_bed_on:
            su, sv, _ = self._near_bed(ahead, rad, np.asarray(s1.surface, float), np.asarray(s1.bed, float), su, sv)
        elif self.profile_code != 0:
            su, sv = self._profiled(ahead, np.asarray(s1.surface, float), np.asarray(s1.bed, float), su, sv)
        u1 = np.where(ok, su, u)
        v1 = np.where(ok, sv, v)
        K.convective_added_mass(rad, phi, u, v, u1, v1, horizon, self.water.rho, xis, f)

    def _torque(self, p, w, om, rad, phi, u, v, tq, cds):
        law, params = self.drag_law.law_id, self.drag_law.params
        grid = getattr(self.field, "grid", None)
        if self.field.uniform:
            if not np.any(om):
                return  # a uniform stream exerts no torque on a non-spinning sphere
            K.uniform_field_torque(w, om, rad, phi, u, v, self.torque_points, self.water.rho, self.water.nu,
                                   law, params, cds, tq)
        elif grid is not None:
            K.neighbourhood_torque(p, w, om, rad, phi, grid.x0, grid.y0, grid.dx, grid.dy, grid.u, grid.v,
                                   grid.depth, self.field.s_max, self.water.rho, self.water.nu, law, params, cds,
                                   tq)
        # meshes: no gridpoint torque yet (documented limitation)

    def __repr__(self):
        return (f"FluidForces(field={self.field!r}, drag_law={self.drag_law.name!r}, xi={self.xi}, "
                f"air={'on' if self.air else 'off'}, profile={self.velocity_profile!r}, torque={self.torque}, basset={self.basset is not None})")
