"""Fluid–particle forces for the DEM (SPEC §6): drag laws, buoyancy with the spherical cap, apparent mass,
fluid torque, free-flight integration and the settling-sphere validation (SPEC §8)."""
from __future__ import annotations

from .drag import DRAG_LAWS, DragLaw
from .field import NoWater, SnapshotField, UniformWater
from .forces import AIR, WATER, Fluid, FluidForces

__all__ = ["DRAG_LAWS", "DragLaw", "NoWater", "SnapshotField", "UniformWater", "AIR", "WATER",
           "Fluid", "FluidForces"]
