"""Fluid–particle forces for the DEM (docs/theory.md, *Fluid forces on a mass*): drag laws, buoyancy with the spherical cap, apparent mass,
fluid torque, free-flight integration and the settling-sphere validation (docs/validation.md, *Settling spheres*)."""
from __future__ import annotations

from .drag import DRAG_LAWS, DragLaw
from .field import NoWater, SnapshotField, UniformWater
from .forces import AIR, WATER, Fluid, FluidForces

__all__ = ["DRAG_LAWS", "DragLaw", "NoWater", "SnapshotField", "UniformWater", "AIR", "WATER",
           "Fluid", "FluidForces"]
