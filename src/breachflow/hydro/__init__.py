"""Hydrodynamics: snapshot Datasets, readers of ADH / HEC-RAS exports, the embedded shallow-water
solver and the sampling layer the DEM reads the field through (SPEC §4, §6)."""
from .snapshot import grid_snapshot, VARIABLE_ATTRS

__all__ = ["grid_snapshot", "VARIABLE_ATTRS"]
