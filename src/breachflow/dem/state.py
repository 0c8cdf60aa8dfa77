"""Particle state of the DEM as a structure of arrays (docs/theory.md, *DEM contact*, report Table 3.1).

Every array is float64 / bool numpy, SI, indexed by particle. Contact properties of a pair (or of a
particle and a boundary) are the minimum of the two partners' values (docs/theory.md, *DEM contact*).

Table 3.1 per-particle parameters and their fields here:

=====================================  ====================  ==========
report                                 field                 unit
=====================================  ====================  ==========
density                                ``density``           kg/m^3
size ``D``                             ``radius`` D/2        m
position                               ``pos``               m
adhesion ``alpha``                     ``adhesion``          N
friction ``beta``                      ``friction``          1
normal / shear stiffness               ``kn``, ``ks``        N/m
contact damping (normal/shear/fric.)   ``c_cn`` ...          N s/m
global damping (transl./rotational)    ``c_gn``              N s/m
                                       ``c_gw``              N m s
rolling friction ``mu_r`` (extension)  ``rolling_friction``  1
=====================================  ====================  ==========

``rolling_friction`` is not in the report (its spheres roll freely); it stands in for the shape
resistance of angular blocks (elastic–plastic rolling spring, :func:`.contact_law.rolling_law`).

Per-particle fluid parameters (:data:`FLUID_FIELDS`, read by :class:`breachflow.fluid.forces.FluidForces`):
``drag_coefficient`` the particle's own Newton-regime drag coefficient (its shape's, e.g. angular rock or a
cube; used at every Reynolds number, in water and in air) and ``lift_coefficient`` its own lift coefficient
(replaces the lift term's C_L where the near-bed lift is on). ``UNSET`` (NaN, the default) means "the
run's": the force model's drag law, the lift term's coefficient. ``added_mass_coefficient`` is the particle's
own apparent-mass coefficient xi (its material's; UNSET: the force model's ``xi``, ``[fluid] xi``). A closure run fills them from each mass's
material when it is placed (:mod:`breachflow.materials`), so that masses of different materials in one run
each feel their own drag.
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields

import numpy as np

from ..errors import InputError

#: per-particle material fields (Table 3.1), in the order used by the kernels
MATERIAL_FIELDS = ("adhesion", "friction", "kn", "ks", "c_cn", "c_cs", "c_cf", "c_gn", "c_gw", "rolling_friction")
#: per-particle fluid parameters (module docstring); ``UNSET`` = the run's drag law / lift coefficient
FLUID_FIELDS = ("drag_coefficient", "lift_coefficient", "added_mass_coefficient")
#: the value of a per-particle fluid parameter that the particle does not set (the run's value applies)
UNSET = float("nan")


@dataclass(frozen=True)
class Material:
    """Contact and damping properties of one material (report Table 3.1), SI.

    ``adhesion`` alpha (N) and ``friction`` beta (-) give the slip limit of the shear spring
    ``u_S_hat = (alpha + beta k_N u_N) / k_S``; ``c_cn``/``c_cs``/``c_cf`` are the normal, shear
    (sticking) and friction (slipping) dashpots; ``c_gn``/``c_gw`` the global damping;
    ``rolling_friction`` mu_r (-) limits the rolling moment ``|M_r| <= mu_r R_r |F_N|`` (0: free rolling).
    """

    density: float = 2650.0
    kn: float = 1.0e7
    ks: float | None = None  # default: kn (report uses equal stiffnesses)
    friction: float = 0.5
    adhesion: float = 0.0
    c_cn: float = 0.0
    c_cs: float = 0.0
    c_cf: float = 0.0
    c_gn: float = 0.0
    c_gw: float = 0.0
    rolling_friction: float = 0.0

    def __post_init__(self):
        for f in fields(self):
            v = getattr(self, f.name)
            if v is None:
                continue
            if not np.isfinite(v) or v < 0:
                raise InputError(f"material parameter {f.name}={v!r} must be finite and >= 0")
        if self.density <= 0 or self.kn <= 0:
            raise InputError("material density and kn must be > 0")

    @property
    def ks_value(self) -> float:
        return self.kn if self.ks is None else self.ks

    def with_restitution(self, e: float, mass: float) -> "Material":
        """Return a copy whose normal dashpot gives restitution *e* for a wall impact of *mass*.

        Inverts ``e = exp(-zeta pi / sqrt(1 - zeta^2))``, ``c = 2 zeta sqrt(k m)`` (docs/theory.md, *DEM contact*).
        """
        if not 0 < e <= 1:
            raise InputError(f"restitution e={e} must be in (0, 1]")
        ln_e = np.log(e)
        zeta = -ln_e / np.sqrt(np.pi**2 + ln_e**2)
        from dataclasses import replace

        return replace(self, c_cn=2.0 * zeta * np.sqrt(self.kn * mass))


def sphere_mass(radius, density):
    """Mass ``rho 4/3 pi r^3`` (kg)."""
    return density * 4.0 / 3.0 * np.pi * np.asarray(radius, float) ** 3


def sphere_inertia(mass, radius):
    """Moment of inertia of a solid sphere ``2/5 m r^2`` (kg m^2)."""
    return 0.4 * np.asarray(mass, float) * np.asarray(radius, float) ** 2


def _grow(a: np.ndarray, n: int) -> np.ndarray:
    shape = (n,) + a.shape[1:]
    out = np.zeros(shape, dtype=a.dtype)
    out[: a.shape[0]] = a
    return out


@dataclass
class ParticleState:
    """Structure of arrays of N spheres (docs/theory.md, *DEM contact*). All float64 SI unless noted.

    ``pos``, ``vel``, ``omega`` (N, 3); ``radius``, ``mass``, ``inertia``, ``density`` (N,);
    Table 3.1 material fields (N,) (see :data:`~breachflow.dem.state.MATERIAL_FIELDS`); ``awake`` (N,) bool — sleeping
    particles are not integrated but remain contact partners; ``active`` (N,) bool — False once a
    particle has left the domain (it is then ignored everywhere, its index stays valid);
    ``vel_prev``/``omega_prev`` the previous step's velocities (the report's scheme needs ``v(t-1)``).
    Indices are stable: particles are only appended, never reordered.
    """

    pos: np.ndarray
    vel: np.ndarray
    omega: np.ndarray
    radius: np.ndarray
    mass: np.ndarray
    inertia: np.ndarray
    density: np.ndarray
    adhesion: np.ndarray
    friction: np.ndarray
    kn: np.ndarray
    ks: np.ndarray
    c_cn: np.ndarray
    c_cs: np.ndarray
    c_cf: np.ndarray
    c_gn: np.ndarray
    c_gw: np.ndarray
    rolling_friction: np.ndarray
    awake: np.ndarray
    active: np.ndarray
    vel_prev: np.ndarray = field(default=None)
    omega_prev: np.ndarray = field(default=None)
    #: the particle's own drag coefficient (``UNSET``: the force model's drag law), module docstring
    drag_coefficient: np.ndarray = field(default=None)
    #: the particle's own lift coefficient (``UNSET``: the lift term's), module docstring
    lift_coefficient: np.ndarray = field(default=None)
    #: the particle's own apparent (added) mass coefficient xi (``UNSET``: the force model's ``xi``)
    added_mass_coefficient: np.ndarray = field(default=None)

    def __post_init__(self):
        if self.vel_prev is None:
            self.vel_prev = self.vel.copy()
        if self.omega_prev is None:
            self.omega_prev = self.omega.copy()
        for name in FLUID_FIELDS:  # states saved before these existed: every particle takes the run's values
            if getattr(self, name) is None:
                setattr(self, name, np.full(self.radius.shape[0], UNSET))
        self.refresh_props()

    # ------------------------------------------------------------------ construction
    @classmethod
    def empty(cls) -> "ParticleState":
        z3 = np.zeros((0, 3))
        z = np.zeros(0)
        return cls(
            pos=z3.copy(), vel=z3.copy(), omega=z3.copy(), radius=z.copy(), mass=z.copy(),
            inertia=z.copy(), density=z.copy(),
            **{name: z.copy() for name in MATERIAL_FIELDS},
            awake=np.zeros(0, bool), active=np.zeros(0, bool),
        )

    @classmethod
    def spheres(cls, pos, radius, material: Material | None = None, vel=None, omega=None) -> "ParticleState":
        """N spheres of one material at *pos* (N, 3) m with *radius* (scalar or (N,)) m."""
        s = cls.empty()
        s.add(pos, radius, material, vel=vel, omega=omega)
        return s

    def add(self, pos, radius, material: Material | None = None, vel=None, omega=None, drag_coefficient=UNSET,
            lift_coefficient=UNSET, added_mass_coefficient=UNSET) -> np.ndarray:
        """Append spheres; returns their indices. Validates finiteness and positivity. *drag_coefficient*,
        *lift_coefficient* and *added_mass_coefficient* (scalar or (n,)) are the particles' own fluid parameters
        (module docstring; ``UNSET``: the run's)."""
        material = material or Material()
        pos = np.atleast_2d(np.asarray(pos, dtype=float))
        if pos.ndim != 2 or pos.shape[1] != 3:
            raise InputError(f"particle positions must have shape (n, 3), got {pos.shape}")
        n = pos.shape[0]
        radius = np.broadcast_to(np.asarray(radius, dtype=float), (n,)).copy()
        vel = np.zeros((n, 3)) if vel is None else np.broadcast_to(np.asarray(vel, float), (n, 3)).copy()
        omega = np.zeros((n, 3)) if omega is None else np.broadcast_to(np.asarray(omega, float), (n, 3)).copy()
        for name, arr in (("position", pos), ("radius", radius), ("velocity", vel), ("omega", omega)):
            if not np.all(np.isfinite(arr)):
                raise InputError(f"particle {name} contains NaN or infinity")
        if np.any(radius <= 0):
            raise InputError("particle radius must be > 0")
        fluid = {}
        for name, v in (("drag_coefficient", drag_coefficient), ("lift_coefficient", lift_coefficient),
                        ("added_mass_coefficient", added_mass_coefficient)):
            a = np.broadcast_to(np.asarray(UNSET if v is None else v, dtype=float), (n,)).copy()
            ok = np.isnan(a) | (np.isfinite(a) & ((a > 0) if name == "drag_coefficient" else (a >= 0)))
            if not ok.all():
                raise InputError(f"particle {name} must be {'> 0' if name == 'drag_coefficient' else '>= 0'} "
                                 f"(or unset), got {a[~ok][0]!r}")
            fluid[name] = a
        mass = sphere_mass(radius, material.density)
        values = dict(
            pos=pos, vel=vel, omega=omega, radius=radius, mass=mass,
            inertia=sphere_inertia(mass, radius), density=np.full(n, material.density),
            adhesion=np.full(n, material.adhesion), friction=np.full(n, material.friction),
            kn=np.full(n, material.kn), ks=np.full(n, material.ks_value), c_cn=np.full(n, material.c_cn),
            c_cs=np.full(n, material.c_cs), c_cf=np.full(n, material.c_cf), c_gn=np.full(n, material.c_gn),
            c_gw=np.full(n, material.c_gw), rolling_friction=np.full(n, material.rolling_friction), awake=np.ones(n, bool), active=np.ones(n, bool),
            vel_prev=vel.copy(), omega_prev=omega.copy(), **fluid,
        )
        n0 = self.n
        for name, v in values.items():
            old = getattr(self, name)
            new = _grow(old, n0 + n)
            new[n0:] = v
            setattr(self, name, new)
        self.refresh_props()
        return np.arange(n0, n0 + n)

    def refresh_props(self) -> None:
        """Rebuild the (N, 8) contact-property table the kernels read; call after editing materials.

        Columns: adhesion, friction, kn, ks, c_cn, c_cs, c_cf, rolling_friction."""
        self._props = np.ascontiguousarray(np.stack(
            [self.adhesion, self.friction, self.kn, self.ks, self.c_cn, self.c_cs, self.c_cf,
             self.rolling_friction], axis=1))

    # ------------------------------------------------------------------ queries
    @property
    def n(self) -> int:
        return self.pos.shape[0]

    def __len__(self) -> int:
        return self.n

    def nbytes(self) -> int:
        return sum(getattr(self, f.name).nbytes for f in fields(self)) + self._props.nbytes

    def kinetic_energy(self) -> float:
        """Translational + rotational kinetic energy (J) of the active particles."""
        a = self.active
        return float(0.5 * np.sum(self.mass[a] * np.sum(self.vel[a] ** 2, axis=1))
                     + 0.5 * np.sum(self.inertia[a] * np.sum(self.omega[a] ** 2, axis=1)))
