"""Hydrodynamics: snapshot Datasets, readers of ADH / HEC-RAS exports, the embedded shallow-water
solver and the sampling layer the DEM reads the field through (docs/theory.md, *Shallow-water equations*, *Fluid forces on a mass*)."""
from .snapshot import (
    grid_snapshot, mesh_snapshot, VARIABLE_ATTRS, DRY_DEPTH, is_mesh, check_plausibility,
    write_snapshot, read_snapshot, validate_snapshot, mesh_triangles,
)
from .sampling import FieldSampler, FieldSample, uniform_snapshot, SAMPLING_METHODS

__all__ = [
    "grid_snapshot", "VARIABLE_ATTRS", "mesh_snapshot", "DRY_DEPTH", "is_mesh", "check_plausibility",
    "write_snapshot", "read_snapshot", "validate_snapshot", "mesh_triangles",
    "FieldSampler", "FieldSample", "uniform_snapshot", "SAMPLING_METHODS", "open_snapshot", "READERS",
]


def __getattr__(name):  # readers import lazily (they are not needed to sample a snapshot)
    if name in ("open_snapshot", "READERS"):
        from . import io

        return getattr(io, name)
    raise AttributeError(name)
