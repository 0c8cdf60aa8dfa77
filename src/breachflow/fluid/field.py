"""Where the fluid forces read the water: a snapshot sampler or an analytic uniform field.

``FluidField`` wraps either a :class:`~breachflow.field.sampling.FieldSampler` (a hydrodynamic
snapshot, bilinear or the report's neighbourhood averaging, docs/theory.md, *Fluid forces on a mass* / Fig 4.4) or
:class:`UniformWater` (still or uniformly flowing water of unbounded extent, for validations such as the
report's settling tube, docs/validation.md, *Settling spheres*).  Both answer ``sample(px, py, radius) -> FieldSample``.
"""
from __future__ import annotations

import numpy as np
import xarray as xr

from ..errors import InputError
from ..field.sampling import SAMPLING_METHODS, FieldSample, FieldSampler


class UniformWater:
    """Water of unbounded horizontal extent: free surface at ``surface`` (m), velocity ``(u, v)`` (m/s).

    ``bed`` (m, default ``-inf``) is only reported; the DEM's boundaries carry the real bed.
    """

    uniform = True

    def __init__(self, surface: float = 0.0, u: float = 0.0, v: float = 0.0, bed: float = -np.inf):
        from ..units import to_si

        self.surface = to_si(surface, name="surface", kind="length", default_unit="m")
        self.u = to_si(u, name="u", kind="speed", default_unit="m/s")
        self.v = to_si(v, name="v", kind="speed", default_unit="m/s")
        self.bed = float(bed)
        if self.bed >= self.surface:
            raise InputError(f"UniformWater: bed {self.bed} m must lie below the surface {self.surface} m")
        self.s_max = 0.0

    def sample(self, px, py, radius=None) -> FieldSample:
        shape = np.broadcast_shapes(np.shape(px), np.shape(py))
        full = lambda val: np.full(shape, float(val))  # noqa: E731
        return FieldSample(bed=full(self.bed), depth=full(self.surface - self.bed), surface=full(self.surface),
                           u=full(self.u), v=full(self.v), inside=np.ones(shape, bool))

    def __repr__(self):
        return f"UniformWater(surface={self.surface}, u={self.u}, v={self.v})"


class NoWater(UniformWater):
    """Air only (the free surface is at ``-inf``): free fall with air drag."""

    def __init__(self):
        self.surface = -np.inf
        self.u = self.v = 0.0
        self.bed = -np.inf
        self.s_max = 0.0


class SnapshotField:
    """A hydrodynamic snapshot seen through a :class:`~breachflow.field.sampling.FieldSampler` (method ``bilinear`` or ``neighbourhood``)."""

    def __init__(self, sampler: FieldSampler):
        self.sampler = sampler
        self.s_max = float(sampler.s_max)
        if sampler.kind == "grid":
            g = sampler.grid_arrays()
            wet = g.depth > 1e-6
            self.grid = g
            self.uniform = bool(wet.all() and np.ptp(g.u) == 0.0 and np.ptp(g.v) == 0.0)
        else:
            m = sampler.mesh_arrays()
            wet = m.depth > 1e-6
            self.grid = None
            self.uniform = bool(wet.all() and np.ptp(m.u) == 0.0 and np.ptp(m.v) == 0.0)

    def sample(self, px, py, radius=None) -> FieldSample:
        return self.sampler.sample(px, py, radius)


def as_field(field, sampling: str = SAMPLING_METHODS.default):
    """A field from None (air only), a float (still water surface elevation, m), a snapshot Dataset,
    a FieldSampler, or an object with ``sample``/``uniform``/``s_max`` (returned as is)."""
    if field is None:
        return NoWater()
    if isinstance(field, (int, float)):
        return UniformWater(surface=float(field))
    if isinstance(field, xr.Dataset):
        return SnapshotField(FieldSampler(field, method=sampling))
    if isinstance(field, FieldSampler):
        return SnapshotField(field)
    if hasattr(field, "sample") and hasattr(field, "uniform"):
        return field
    raise InputError(f"fluid field: expected a snapshot Dataset, FieldSampler, UniformWater or None, got {type(field).__name__}")
