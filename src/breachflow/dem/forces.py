"""Force models of the DEM and the force assembly the integrators call (docs/theory.md, *DEM contact*, *Fluid forces on a mass*; the ForceModel protocol below).

A :class:`ForceModel` adds its force (N) and torque (N m) per particle into whole arrays, evaluated at
the kinematic state the integrator passes (e.g. the report scheme's predicted positions, Step 7H).
Integrators compute ``a = (F_contacts + F_gravity + sum(models) + F_damping) / (m + sum(added_mass))``
and never know which models exist. Fluid forces (docs/theory.md, *Fluid forces on a mass*) plug in as a further ForceModel. A model with a
memory (the Basset history) is told each accepted state by an optional ``commit(state, pos, vel, t)`` and
saved with the DEM state through optional ``state_arrays`` / ``restore_state`` (:mod:`.memory`).
"""
from __future__ import annotations

from typing import Protocol, runtime_checkable

import numba
import numpy as np

from .state import ParticleState

#: standard gravity (m/s^2), acting along -z
G = 9.80665


@runtime_checkable
class ForceModel(Protocol):
    """A body force on the particles (fluid forces, gravity, ...). One Python call per step."""

    def added_mass(self, state: ParticleState) -> np.ndarray | None:
        """Extra translational mass (kg) per particle, or None. A model may accept ``idx=`` and then return
        the rows *idx* only (a ``static_models`` simulation asks for its awake particles)."""

    def accumulate(self, state: ParticleState, pos, vel, omega, t: float, force, torque) -> None:
        """ADD this model's force (N) and torque (N m), (N, 3) each, at the given kinematic state."""


@numba.njit(cache=True, error_model="numpy")
def _add_gravity(idx, mass, g, force):
    for k in range(idx.shape[0]):
        i = idx[k]
        force[i, 0] += mass[i] * g[0]
        force[i, 1] += mass[i] * g[1]
        force[i, 2] += mass[i] * g[2]


class Gravity:
    """Gravity ``f_G = rho_S V g = m g`` (docs/theory.md, *Fluid forces on a mass*); buoyancy belongs to the fluid model."""

    def __init__(self, g=(0.0, 0.0, -G)):
        self.g = np.asarray(g, dtype=float)

    def added_mass(self, state):
        return None

    def accumulate(self, state, pos, vel, omega, t, force, torque, idx=None):
        if idx is None:
            idx = np.flatnonzero(state.active)
        _add_gravity(idx, state.mass, self.g, force)


@numba.njit(cache=True, error_model="numpy")
def add_global_damping(idx, vel, omega, c_gn, c_gw, scale, force, torque):
    """Global damping ``d_GN = -c_GN v``, ``d_GW = -c_GW w`` times *scale* (report: 1/2), docs/theory.md, *DEM contact*."""
    for k in range(idx.shape[0]):
        i = idx[k]
        for d in range(3):
            force[i, d] -= scale * c_gn[i] * vel[i, d]
            torque[i, d] -= scale * c_gw[i] * omega[i, d]


@numba.njit(cache=True, error_model="numpy")
def zero_rows(idx, a, b):
    for k in range(idx.shape[0]):
        i = idx[k]
        for d in range(3):
            a[i, d] = 0.0
            b[i, d] = 0.0
