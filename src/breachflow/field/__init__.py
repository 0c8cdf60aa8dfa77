"""Hydrodynamic fields: the snapshot Dataset (grid or mesh, CF conventions), its coordinate reference
system, the fields derived from a depth-averaged flow and the sampling layer the DEM reads the field
through. Readers and writers of model exports are in :mod:`breachflow.io`."""
from .snapshot import (
    grid_snapshot, mesh_snapshot, VARIABLE_ATTRS, DRY_DEPTH, is_mesh, check_plausibility,
    write_snapshot, read_snapshot, validate_snapshot, mesh_triangles,
)
from .sampling import FieldSampler, FieldSample, uniform_snapshot, SAMPLING_METHODS

__all__ = [
    "grid_snapshot", "VARIABLE_ATTRS", "mesh_snapshot", "DRY_DEPTH", "is_mesh", "check_plausibility",
    "write_snapshot", "read_snapshot", "validate_snapshot", "mesh_triangles",
    "FieldSampler", "FieldSample", "uniform_snapshot", "SAMPLING_METHODS",
]
