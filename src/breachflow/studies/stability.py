"""Stone stability from the DEM and the fluid forces: the critical velocity of a stone on a rock bed.

The set-up a closure engineer has in mind when quoting Izbash: a stone of diameter ``D`` lying in a
pocket of a bed of equal stones, under a current of depth ``h`` and depth-averaged velocity ``U``.
Here the bed is a fixed hexagonal close-packed layer of spheres of diameter ``D``; the test stone sits in
a pocket of three of them (an *exposed* stone: nothing shelters it); the current flows along ``+x``.
The water's bed level (``z = 0`` of the velocity profile, :mod:`breachflow.fluid.profile`) is the
crest of the fixed layer lowered by ``bed_offset * D`` (default 0.2 D, the theoretical bed level of a
rough rock bed after Einstein & El-Samni 1949); the log-law roughness is ``k_s = 2 D``.

:func:`critical_velocity` bisects on ``U``: a DEM run of ``duration`` (default ``10 sqrt(D/g)``) in the
frozen uniform current with :class:`~breachflow.fluid.forces.FluidForces` (drag, buoyancy, apparent
mass; no lift force exists in the model) and the closure run's default rock material; the stone "moves"
when its horizontal displacement exceeds ``D/4``. The contact stiffness is scaled ``k_N ∝ D^2`` from
the closure default (2e7 N/m for 2 m stones) so that overlaps are the same fraction of ``D`` at every
size. Results are compared with :mod:`breachflow.scenario.stone` (Izbash, Shields) in the tests and in
docs/validation.md, *Stone stability: Izbash and Shields*.

Which velocity Izbash's coefficient refers to: Izbash's ``u_c`` is the flow velocity *in the vicinity of
the stone* (Izbash 1935, *Construction of dams by dumping stones into flowing water*; the riprap
literature calls it the velocity against the stone and defines a reference velocity one stone diameter
above the bed, e.g. USACE/FHWA riprap design, "reference velocity V_r at a distance D50 above the bed").
Over a dam crest, where Izbash measured, the flow accelerates and its profile is nearly uniform, so
engineers apply it to the depth-averaged velocity — a use limited to relative depths ``h/D`` of about
5–10. With a developed log profile the depth-averaged ``U`` exceeds the velocity at the stone by
``(ln(30 h/k_s) - 1) / ln(30 z/k_s)`` (1.2–3.1 at the stone's centre for ``h/D`` = 2–100, ``k_s = 2 D``),
so a criterion in depth-averaged ``U`` must grow with ``h/D`` (Shields does; Izbash does not).
:func:`near_bed_velocity` gives the velocity at ``z = D`` above the bed level, the reference the
comparison with Izbash uses for the profiles (docs/validation.md table).

Drag at the centre height vs over the stone's height: with the drag of the mean ``u|u|`` over the
stone's projected area (Wiberg & Smith 1987, Water Resour. Res. 23(8)), the log-law effective velocity of
this bed stone is 0.97 times its centre value (the lowest ~5 % of its height lies below ``z0 = k_s/30``,
where the log law has no flow); the model keeps the centre value (:mod:`breachflow.fluid.profile`).
"""
from __future__ import annotations

import math

import numpy as np

from ..dem import DemSimulation, Material
from ..fluid.field import UniformWater
from ..fluid.forces import FluidForces
from ..fluid.profile import factors as profile_factors

G = 9.80665


def _bed_layer(D, n=3):
    """Centres of a hexagonal close-packed layer (rows along x) of spheres of diameter D around the origin."""
    pts = []
    for j in range(-n, n + 1):
        for i in range(-n - 1, n + 2):
            pts.append((i * D + 0.5 * D * (j % 2), j * D * math.sqrt(3) / 2, 0.0))
    return np.array(pts)


def stone_moves(U, D, depth, *, velocity_profile="uniform", drag_law="report", density=2650.0,
                bed_offset=0.2, material: Material | None = None, duration=None, direction=(1.0, 0.0)) -> bool:
    """One DEM run: does a stone of diameter *D* in a bed pocket move under the current *U* (m/s)?"""
    mat = material or Material(density=density, kn=2.0e7 * (D / 2.0) ** 2, friction=0.6, rolling_friction=0.3)
    mat = mat.with_restitution(0.3, density * math.pi / 6 * D ** 3)
    bed = _bed_layer(D)
    # a pocket of three bed spheres: between (0,0), (D,0) and (D/2, D sqrt3/2)
    pocket = np.array([0.5 * D, D * math.sqrt(3) / 6, D * math.sqrt(2.0 / 3.0)])
    crest = 0.5 * D
    z_bed = crest - bed_offset * D
    d = np.asarray(direction, float)
    d = d / np.hypot(*d)
    water = UniformWater(surface=z_bed + depth, u=U * d[0], v=U * d[1], bed=z_bed)
    fluid = FluidForces(water, drag_law=drag_law, velocity_profile=velocity_profile, roughness=2.0 * D, air=None)
    sim = DemSimulation(models=[fluid], sleeping=False, static_models=True)
    ids = sim.add_particles(bed, 0.5 * D, mat)
    sim.fix_particles(ids)
    k = sim.add_particles(pocket[None, :] + [0.0, 0.0, 1e-4 * D], 0.5 * D, mat)[0]
    T = 10.0 * math.sqrt(D / G) if duration is None else float(duration)
    x0 = sim.state.pos[k, :2].copy()
    n = max(1, int(math.ceil(T / sim.dt / 50)))
    for _ in range(50):
        sim.step(n)
        if np.hypot(*(sim.state.pos[k, :2] - x0)) > 0.25 * D:
            return True
    return False


def near_bed_velocity(U, D, depth, *, velocity_profile="log", roughness_factor=2.0, height=1.0):
    """The velocity one stone diameter above the bed level (``z = height * D``), ``U * profile_factor``
    (log law with ``k_s = roughness_factor * D``, as :func:`stone_moves`): the near-stone reference
    velocity of Izbash's coefficient for a depth-averaged *U* (m/s) in water *depth* (m)."""
    return U * profile_factors(velocity_profile, height * D, depth, roughness_factor * D)


def critical_velocity(D, depth, *, velocity_profile="uniform", drag_law="report", density=2650.0,
                      bed_offset=0.2, rel_tol=0.01, u_max=None, material: Material | None = None) -> float:
    """Depth-averaged velocity (m/s) at which the exposed stone of :func:`stone_moves` starts to move
    (bisection to *rel_tol*); ``inf`` if it stays at *u_max* (default 5 × Izbash-embedded)."""
    delta = (density - 1000.0) / 1000.0
    hi = 5.0 * 1.2 * math.sqrt(2 * G * delta * D) if u_max is None else float(u_max)
    kw = dict(velocity_profile=velocity_profile, drag_law=drag_law, density=density, bed_offset=bed_offset,
              material=material)
    if not stone_moves(hi, D, depth, **kw):
        return math.inf
    lo = 0.0
    while hi - lo > rel_tol * hi:
        mid = 0.5 * (lo + hi)
        if stone_moves(mid, D, depth, **kw):
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi)


def units_move(U, units, depth, *, velocity_profile="uniform", drag_law="report", bed_offset=0.2, duration=None,
               direction=(1.0, 0.0)) -> list[bool]:
    """One DEM run of several stones, each in a pocket of its own bed, in ONE scene and one current: which move?

    *units* is a list of dicts ``{"D": m, "material": Material, "drag_coefficient": C_D or None}`` — e.g. the
    units of a mix of closure materials, each with its own friction, rolling resistance and shape drag carried
    per particle (:class:`~breachflow.dem.state.ParticleState`; None: the scene's *drag_law*). Each pocket is
    the set-up of :func:`stone_moves` (a fixed layer of the same units, the stone in a pocket of three, the
    water's bed level ``bed_offset * D`` below the layer's crest); the pockets lie side by side, 16 stone
    diameters apart across the flow, at a common bed level, so that no stone touches another's bed. A stone
    "moves" when it is displaced by more than ``D/4`` within *duration* (default ``10 sqrt(D_max/g)``)."""
    d = np.asarray(direction, float)
    d = d / np.hypot(*d)
    water = UniformWater(surface=depth, u=U * d[0], v=U * d[1], bed=0.0)
    fluid = FluidForces(water, drag_law=drag_law, velocity_profile=velocity_profile,
                        roughness=2.0 * max(u["D"] for u in units), air=None)
    sim = DemSimulation(models=[fluid], sleeping=False, static_models=True)
    gap = 16.0 * max(u["D"] for u in units)
    stones, starts = [], []
    for k, unit in enumerate(units):
        D, mat = float(unit["D"]), unit["material"]
        mat = mat.with_restitution(0.3, mat.density * math.pi / 6 * D ** 3)
        cd = unit.get("drag_coefficient")
        own = {} if cd is None else {"drag_coefficient": float(cd)}
        shift = np.array([0.0, k * gap, (bed_offset - 0.5) * D])  # the layer's crest bed_offset D above z = 0
        ids = sim.add_particles(_bed_layer(D) + shift, 0.5 * D, mat, **own)
        sim.fix_particles(ids)
        pocket = np.array([0.5 * D, D * math.sqrt(3) / 6, D * math.sqrt(2.0 / 3.0) + 1e-4 * D]) + shift
        stones.append(sim.add_particles(pocket[None, :], 0.5 * D, mat, **own)[0])
    starts = sim.state.pos[stones, :2].copy()
    dmax = max(u["D"] for u in units)
    T = 10.0 * math.sqrt(dmax / G) if duration is None else float(duration)
    n = max(1, int(math.ceil(T / sim.dt / 50)))
    moved = np.zeros(len(units), bool)
    limit = np.array([0.25 * u["D"] for u in units])
    for _ in range(50):
        sim.step(n)
        moved |= np.hypot(*(sim.state.pos[stones, :2] - starts).T) > limit
        if moved.all():
            break
    return [bool(m) for m in moved]


def critical_velocities(units, depth, *, rel_tol=0.01, u_max=None, **kw) -> list[float]:
    """Depth-averaged velocity (m/s) at which each stone of :func:`units_move` starts to move *in the scene of all
    of them* (one bisection per stone to *rel_tol*, every run with all the stones); ``inf`` where a stone stays at
    *u_max* (default 5 × Izbash-embedded of the lightest, largest unit)."""
    if u_max is None:
        u_max = max(5.0 * 1.2 * math.sqrt(2 * G * (u["material"].density - 1000.0) / 1000.0 * u["D"]) for u in units)
    out = []
    for k in range(len(units)):
        hi = float(u_max)
        if not units_move(hi, units, depth, **kw)[k]:
            out.append(math.inf)
            continue
        lo = 0.0
        while hi - lo > rel_tol * hi:
            mid = 0.5 * (lo + hi)
            if units_move(mid, units, depth, **kw)[k]:
                hi = mid
            else:
                lo = mid
        out.append(0.5 * (lo + hi))
    return out
