"""Boundaries of the DEM: planes / walls (fixed, velocity- or force-controlled) and the terrain as a
height field on the hydrodynamic grid (docs/theory.md, *DEM contact*, report Table 3.1 "for each boundary [k]").

Each boundary carries its own Table 3.1 contact properties (a :class:`~.state.Material`); the contact
with a particle uses the minimum of the two (docs/theory.md, *DEM contact*). Shear histories are kept per particle.
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError
from . import pair_contacts
from .state import Material


def _wall_props(material: Material) -> np.ndarray:
    m = material
    return np.array([m.adhesion, m.friction, m.kn, m.ks_value, m.c_cn, m.c_cs, m.c_cf, m.rolling_friction],
                    dtype=float)


class Boundary:
    """Base: holds the material row and the per-particle shear (``hist``, m) and rolling-moment
    (``rhist``, N m) histories."""

    moving = False

    def __init__(self, material: Material | None):
        self.material = material or Material()
        self.props = _wall_props(self.material)
        self.hist = np.zeros((0, 3))
        self.rhist = np.zeros((0, 3))

    def resize(self, n: int) -> None:
        if self.hist.shape[0] < n:
            for name in ("hist", "rhist"):
                old = getattr(self, name)
                new = np.zeros((n, 3))
                new[: old.shape[0]] = old
                setattr(self, name, new)

    def advance(self, dt: float) -> None:
        """Move the boundary over one step (nothing for fixed ones)."""


class Plane(Boundary):
    """Infinite plane through *point* with *normal* pointing into the domain.

    ``control="fixed"`` (default), ``"velocity"`` (displacement controlled: moves with *velocity*,
    m/s) or ``"force"`` (force controlled: a body of *mass* kg pushed by *applied_force* (N, vector)
    plus the particle reactions, moving along its normal only).
    """

    def __init__(self, point, normal, material: Material | None = None, *, control: str = "fixed",
                 velocity=(0.0, 0.0, 0.0), applied_force=(0.0, 0.0, 0.0), mass: float | None = None):
        super().__init__(material)
        self.point = np.asarray(point, dtype=float).copy()
        n = np.asarray(normal, dtype=float)
        norm = np.linalg.norm(n)
        if self.point.shape != (3,) or n.shape != (3,) or not np.isfinite(norm) or norm == 0:
            raise InputError("plane point and normal must be finite 3-vectors, normal non-zero")
        self.normal = n / norm
        if control not in ("fixed", "velocity", "force"):
            raise InputError(f"plane control must be 'fixed', 'velocity' or 'force', got {control!r}")
        self.control = control
        self.velocity = np.asarray(velocity, dtype=float).copy()
        self.applied_force = np.asarray(applied_force, dtype=float).copy()
        if control == "force" and (mass is None or not mass > 0):
            raise InputError("a force-controlled plane needs a mass > 0 (kg)")
        self.mass = mass
        self.moving = control != "fixed"
        self.reaction = np.zeros(3)
        if control == "fixed":
            self.velocity[:] = 0.0

    def forces(self, idx, state, dt, force, torque, lo=0.0, hi=0.0, law=0) -> int:
        """Add the contact forces on particles *idx*, averaged over the force interval ``[lo, hi]`` (s,
        :func:`.contact_law.contact_law`; *law*: kernel code of the contact law, :data:`.contact_law.contact_laws`);
        returns the number of pair_contacts."""
        self.reaction[:] = 0.0
        return pair_contacts.plane_forces(idx, self.point, self.normal, self.velocity, self.props, self.hist,
                                     self.rhist, state.pos, state.vel, state.omega, state.radius, state.mass,
                                     state.inertia, state._props, dt, force, torque, self.reaction, lo, hi,
                                     state.vel_h, state.omega_h, law)

    def advance(self, dt: float) -> None:
        if self.control == "force":
            # semi-implicit Euler along the normal: m a = (F_applied + reaction) . n
            a = np.dot(self.applied_force + self.reaction, self.normal) / self.mass
            self.velocity = (np.dot(self.velocity, self.normal) + a * dt) * self.normal
        if self.control != "fixed":
            self.point = self.point + self.velocity * dt


class HeightField(Boundary):
    """Terrain ``z = bed(x, y)``: bilinear through a regular grid of cell-centre values.

    *x* (nx,), *y* (ny,) increasing and evenly spaced (m), *bed* (ny, nx) m — the hydrodynamic
    snapshot's grid (schema data_schemas/snapshot_grid.json); :meth:`from_snapshot` takes it from a snapshot Dataset.
    """

    def __init__(self, x, y, bed, material: Material | None = None, roughness=None):
        super().__init__(material)
        #: the bed's roughness (:class:`breachflow.fluid.bed.BedRoughness`; None: smooth): a rough bed adds the
        #: pocket columns ``(d_bed, z_star)`` to the contact properties (:mod:`breachflow.dem.pocket`)
        self.roughness = roughness
        if roughness is not None:
            self.props = roughness.wall_props(self.props)
        x = np.asarray(x, float)
        y = np.asarray(y, float)
        bed = np.asarray(bed, float)
        if x.ndim != 1 or y.ndim != 1 or x.size < 2 or y.size < 2 or bed.shape != (y.size, x.size):
            raise InputError(f"height field needs x (nx>=2), y (ny>=2) and bed (ny, nx); got "
                             f"{x.shape}, {y.shape}, {bed.shape}")
        for name, a in (("x", x), ("y", y), ("bed_elevation", bed)):
            if not np.all(np.isfinite(a)):
                raise InputError(f"height field {name} contains NaN or infinity")
        for name, a in (("x", x), ("y", y)):
            d = np.diff(a)
            if np.any(d <= 0) or not np.allclose(d, d[0], rtol=1e-6, atol=0):
                raise InputError(f"height field {name} must be increasing and evenly spaced")
        self.x0, self.y0 = float(x[0]), float(y[0])
        self.hx, self.hy = float(x[1] - x[0]), float(y[1] - y[0])
        self.bed = np.ascontiguousarray(bed)

    @classmethod
    def from_snapshot(cls, snapshot, material: Material | None = None, time_index: int = 0,
                      roughness=None) -> "HeightField":
        bed = snapshot["bed_elevation"]
        if "time" in bed.dims:
            bed = bed.isel(time=time_index)
        return cls(snapshot["x"].values, snapshot["y"].values, bed.transpose("y", "x").values, material, roughness)

    def elevation(self, px, py):
        """Bed elevation (m) of the bilinear surface at points (px, py)."""
        px = np.atleast_1d(np.asarray(px, float))
        py = np.atleast_1d(np.asarray(py, float))
        return np.array([pair_contacts._bilinear(self.x0, self.y0, self.hx, self.hy, self.bed, a, b)[0]
                         for a, b in zip(px, py)])

    def forces(self, idx, state, dt, force, torque, lo=0.0, hi=0.0, law=0) -> int:
        """As :meth:`Plane.forces` (no reaction is kept)."""
        return pair_contacts.heightfield_forces(idx, self.x0, self.y0, self.hx, self.hy, self.bed, self.props,
                                           self.hist, self.rhist, state.pos, state.vel, state.omega,
                                           state.radius, state.mass, state.inertia, state._props, dt, force,
                                           torque, lo, hi, state.vel_h, state.omega_h, law)
