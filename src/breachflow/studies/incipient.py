"""Incipient motion of a mass on a rough bed in the DEM: the critical flow of one sphere resting on the
terrain height field with a bed of grains ``d_bed`` (:mod:`breachflow.fluid.bed`), under a steady current
with the near-bed forces (:mod:`breachflow.fluid.nearbed`). The validations of ``docs/bed-and-forces.md``:
Shields' critical parameter (a grain on a bed of the same grains) and Izbash's coefficient (rock with the
drag coefficient of angular stones, ``C_D ~ 1``).

:func:`moves` is one DEM run of ``duration`` (default ``10 sqrt(D/g)``) in a uniform current on a flat grid
field (the fused force path of the closure runs); the sphere "moves" when its horizontal displacement exceeds
``D/4``. :func:`critical_velocity` bisects on the depth-averaged velocity. The shear velocity of a
depth-averaged log-law flow is ``u* = kappa U / (ln(30 h / k_s) - 1)``, Shields' parameter
``theta = u*^2 / (Delta g D)``.
"""
from __future__ import annotations

import math

import numpy as np

from ..dem import DemSimulation, HeightField, Material
from ..field.snapshot import grid_snapshot
from ..fluid import nearbed as NB
from ..fluid.bed import KS_PER_GRAIN, BedRoughness
from ..fluid.forces import FluidForces

G = 9.80665


def _flat_field(D, depth, U, direction, cells=8):
    """A flat bed at z = 0 under water *depth* flowing at *U* along *direction*, a square of ``cells`` D."""
    x = np.linspace(-cells * D, cells * D, 2 * cells + 1)
    X, _ = np.meshgrid(x, x)
    z = np.zeros_like(X)
    return x, grid_snapshot(x, x, z, z + depth, z + U * direction[0], z + U * direction[1])


def moves(U, D, depth, *, d_bed=None, drag_law="report", density=2650.0, friction=0.6, rolling_friction=0.3,
          near_bed=None, velocity_profile="log", offset=(0.0, 0.0), direction=(1.0, 0.0), duration=None) -> bool:
    """One DEM run: does a sphere of diameter *D* resting on a bed of grains *d_bed* (default D) move under the
    depth-averaged current *U* (m/s) in water *depth* (m)? *near_bed*: the parameter vector (default: lift and
    turbulence at their defaults); *offset* the sphere's position within the grid cell (m)."""
    d_bed = D if d_bed is None else float(d_bed)
    d = np.asarray(direction, float)
    d = d / np.hypot(*d)
    x, snap = _flat_field(D, depth, U, d)
    mat = Material(density=density, kn=2.0e7 * (D / 2.0) ** 2, friction=friction, rolling_friction=rolling_friction)
    mat = mat.with_restitution(0.3, density * math.pi / 6 * D ** 3)
    bed = BedRoughness("natural", d_bed)
    terrain = HeightField(x, x, np.zeros((x.size, x.size)), mat, roughness=bed)
    bedp = NB.parameters() if near_bed is None else near_bed
    fluid = FluidForces(snap, drag_law=drag_law, velocity_profile=velocity_profile, roughness=bed.ks, air=None,
                        near_bed=bedp)
    sim = DemSimulation(boundaries=[terrain], models=[fluid], sleeping=False, static_models=True)
    p0 = np.array([offset[0], offset[1], 0.5 * D - 1e-6 * D])
    k = sim.add_particles(p0[None, :], 0.5 * D, mat)[0]
    T = 10.0 * math.sqrt(D / G) if duration is None else float(duration)
    n = max(1, int(math.ceil(T / sim.dt / 40)))
    for _ in range(40):
        sim.step(n)
        if np.hypot(*(sim.state.pos[k, :2] - p0[:2])) > 0.25 * D:
            return True
    return False


def critical_velocity(D, depth, *, rel_tol=0.02, u_max=None, **kw) -> float:
    """Depth-averaged velocity (m/s) at which the sphere of :func:`moves` starts to move (bisection to *rel_tol*);
    ``inf`` if it stays at *u_max* (default 4 x Izbash's embedded-stone velocity)."""
    delta = (kw.get("density", 2650.0) - 1000.0) / 1000.0
    hi = 4.0 * 1.2 * math.sqrt(2 * G * delta * D) if u_max is None else float(u_max)
    if not moves(hi, D, depth, **kw):
        return math.inf
    lo = 0.0
    while hi - lo > rel_tol * hi:
        mid = 0.5 * (lo + hi)
        if moves(mid, D, depth, **kw):
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi)


def shear_velocity(U, depth, k_s, kappa=NB.KAPPA_VK):
    """``u*`` (m/s) of a depth-averaged log-law flow *U* in *depth* over roughness *k_s*."""
    return kappa * U / (math.log(30.0 * depth / k_s) - 1.0)


def critical_shields(D, depth, *, density=2650.0, **kw) -> float:
    """Shields' critical parameter ``theta_c = u*_c^2 / (Delta g D)`` of a sphere *D* on a bed of the same grains."""
    Uc = critical_velocity(D, depth, density=density, **kw)
    us = shear_velocity(Uc, depth, KS_PER_GRAIN * kw.get("d_bed", D) if kw.get("d_bed") else KS_PER_GRAIN * D)
    return us ** 2 / ((density - 1000.0) / 1000.0 * G * D)


def izbash_coefficient(D, depth, *, density=2650.0, **kw) -> float:
    """Izbash's ``C = U_c / sqrt(2 g Delta D)`` of the critical depth-averaged velocity of :func:`critical_velocity`."""
    Uc = critical_velocity(D, depth, density=density, **kw)
    return Uc / math.sqrt(2.0 * G * (density - 1000.0) / 1000.0 * D)
