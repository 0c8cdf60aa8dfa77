"""Discrete element method for the dropped masses (docs/theory.md, *DEM contact*): spheres with linear spring–dashpot
contacts, Coulomb friction with adhesion and shear history, boundaries (planes, moving walls, terrain
height field), named integrators, sleeping, and equilibrium detection."""
from __future__ import annotations

from .boundaries import HeightField, Plane
from .forces import G, ForceModel, Gravity
from .integrators import integrators
from .simulation import DemSimulation, EquilibriumResult
from .state import MATERIAL_FIELDS, Material, ParticleState, sphere_inertia, sphere_mass
from .timestep import SAFETY, check_dt, recommended_dt, stable_dt

__all__ = [
    "DemSimulation", "EquilibriumResult", "ForceModel", "G", "Gravity", "HeightField", "MATERIAL_FIELDS",
    "Material", "ParticleState", "Plane", "SAFETY", "check_dt", "integrators", "recommended_dt",
    "sphere_inertia", "sphere_mass", "stable_dt",
]
