"""Closure materials: what is dumped into the breach, and what makes each unit move.

A closure material draws unit masses (kg) from its grading and carries the parameters the DEM and the fluid
forces read — plain fields, so that any force model can use them:

``density``            solid density of the unit (kg/m³; for a bag or a soil mass its bulk saturated density)
``drag_coefficient``   Newton-regime drag coefficient of the unit's shape (None: the ``[fluid]`` drag law, spheres)
``lift_coefficient``   lift coefficient of a unit resting on the bed (None: no lift, the model's default)
``friction``           Coulomb friction between units (-)
``rolling_friction``   rolling resistance mu_r of the volume-equivalent sphere (-), shape's resistance to roll/tip
``shape``              ``"sphere"``, ``"angular"``, ``"cube"``, ``"bag"``, ``"block"``
``porosity``           porosity of a dumped layer of the units (-)
``added_mass_coefficient``  optional: the unit's apparent (added) mass coefficient xi (None or absent: ``[fluid] xi``)

The DEM body is always the volume-equivalent sphere, diameter ``(6 M / (pi rho))^(1/3)``; the nominal
diameter of a unit is ``D_n = (M / rho)^(1/3)`` (the side of the cube of equal volume, EN 13383's size).

Materials are chosen by name from the registry :data:`MATERIALS` (entry-point group
``breachflow.materials``): the EN 13383-1 standard rock gradings ``HMA_300_1000`` … ``HMA_10000_15000`` and
``LMA_5_40`` … ``LMA_60_300`` (:mod:`breachflow.materials.rock`), ``big_bag``, ``concrete_cube``, ``stabilized_soil``
(:mod:`breachflow.materials.units`) and ``sphere`` (the spheres of ``[placement] diameter`` and ``density``, as before). See the
documentation page *Materials and the seal*.
"""
from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

from ..errors import InputError
from ..registry import Registry

#: closure materials by name; ``MATERIALS.get(name)`` returns a factory (class or function) taking keyword
#: parameters and returning a :class:`ClosureMaterial`
MATERIALS: Registry = Registry("closure material", "breachflow.materials")


@runtime_checkable
class ClosureMaterial(Protocol):
    """What the placement and the DEM need from a material."""

    name: str
    density: float
    drag_coefficient: float | None
    lift_coefficient: float | None
    friction: float
    rolling_friction: float
    shape: str
    porosity: float

    def sample_masses(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """*n* unit masses (kg) drawn from the material's grading with *rng*."""


def nominal_diameter(mass, density) -> np.ndarray:
    """``D_n = (M / rho)^(1/3)`` (m): the side of the cube of the unit's volume (EN 13383-1)."""
    return np.cbrt(np.asarray(mass, float) / np.asarray(density, float))


def sphere_diameter(mass, density) -> np.ndarray:
    """Diameter (m) of the sphere of the unit's volume, ``(6/pi)^(1/3) D_n`` (the DEM body)."""
    return np.cbrt(6.0 * np.asarray(mass, float) / (np.pi * np.asarray(density, float)))


def get_material(spec, **params) -> ClosureMaterial:
    """A material from a name (with keyword parameters), a ``{"name": ..., **params}`` table, or an instance."""
    if isinstance(spec, dict):
        spec = dict(spec)
        try:
            name = spec.pop("name")
        except KeyError:
            raise InputError(f"material table {spec!r} needs a 'name'") from None
        return get_material(name, **spec, **params)
    if not isinstance(spec, str):
        if isinstance(spec, ClosureMaterial):
            return spec
        raise InputError(f"material must be a name or a table, got {spec!r}")
    _load_builtins()
    factory = MATERIALS.get(spec)
    try:
        return factory(**params)
    except TypeError as exc:
        raise InputError(f"material {spec!r}: bad parameters {params!r} ({exc})") from None


def _load_builtins() -> None:
    from . import rock, units  # noqa: F401  (registering imports)


class MaterialMix:
    """Several materials dumped together, each with a mass fraction of the delivered tonnage.

    Units are drawn material by material with probabilities proportional to ``fraction / mean unit mass``
    (so that the fractions hold for the *tonnage*, not the number of units).
    """

    def __init__(self, materials, fractions=None):
        self.materials = [m if isinstance(m, ClosureMaterial) else get_material(m) for m in materials]
        if not self.materials:
            raise InputError("material: give at least one material")
        f = np.ones(len(self.materials)) if fractions is None else np.asarray(fractions, float)
        if f.shape != (len(self.materials),) or np.any(~np.isfinite(f)) or np.any(f < 0) or f.sum() <= 0:
            raise InputError(f"material fractions {fractions!r} must be one non-negative number per material "
                             f"({len(self.materials)}), not all zero")
        self.fractions = f / f.sum()
        for m in self.materials:
            xi = getattr(m, "added_mass_coefficient", None)
            if xi is not None and not (isinstance(xi, (int, float)) and np.isfinite(xi) and xi >= 0):
                raise InputError(f"material {m.name}: added_mass_coefficient must be a number >= 0, got {xi!r}")

    @property
    def name(self) -> str:
        return "+".join(m.name for m in self.materials)

    def mean_unit_mass(self, m, rng_seed=12345, n=4000) -> float:
        return float(np.mean(m.sample_masses(np.random.default_rng(rng_seed), n)))

    def sample(self, rng: np.random.Generator, n: int):
        """``(mass, density, index)`` of *n* units: mass (kg), density (kg/m³), index into ``materials``."""
        if len(self.materials) == 1:
            m = self.materials[0]
            return m.sample_masses(rng, n), np.full(n, m.density), np.zeros(n, int)
        w = self.fractions / np.array([self.mean_unit_mass(m) for m in self.materials])
        idx = rng.choice(len(self.materials), size=n, p=w / w.sum())
        mass = np.empty(n)
        rho = np.empty(n)
        for k, m in enumerate(self.materials):
            sel = idx == k
            if sel.any():
                mass[sel] = m.sample_masses(rng, int(sel.sum()))
                rho[sel] = m.density
        return mass, rho, idx

    def dem_parameters(self) -> dict:
        """The run-wide values of the mix: tonnage-weighted friction and rolling resistance (None where a
        material has none, e.g. ``sphere``), the drag coefficient all its materials share (None: they differ, or
        none has one), the tonnage-weighted lift coefficient (None unless every material has one).

        The DEM does not use one value for all masses: each mass carries its own material's values
        (:meth:`unit_parameters`); these are what a summary of the run (and the "not closable" verdict's
        rolling speed) quotes."""
        def weighted(name):
            vals = [getattr(m, name) for m in self.materials]
            return None if any(v is None for v in vals) else float(np.dot(self.fractions, vals))

        cds = {m.drag_coefficient for m in self.materials}
        return {"friction": weighted("friction"), "rolling_friction": weighted("rolling_friction"),
                "drag_coefficient": cds.pop() if len(cds) == 1 else None,
                "drag_coefficient_mean": weighted("drag_coefficient"), "lift_coefficient": weighted("lift_coefficient")}

    def unit_parameters(self) -> list[dict]:
        """Per material of the mix (in order, the index :meth:`sample` returns): what each of its masses
        carries in the DEM and the fluid forces — ``name``, ``friction``, ``rolling_friction``,
        ``drag_coefficient``, ``lift_coefficient``, ``added_mass_coefficient`` (None: the run's ``[dem]`` value,
        drag law, lift term, ``[fluid] xi``)."""
        return [{"name": m.name, "friction": m.friction, "rolling_friction": m.rolling_friction,
                 "drag_coefficient": m.drag_coefficient, "lift_coefficient": m.lift_coefficient,
                 "added_mass_coefficient": getattr(m, "added_mass_coefficient", None)}
                for m in self.materials]


__all__ = ["MATERIALS", "ClosureMaterial", "MaterialMix", "get_material", "nominal_diameter", "sphere_diameter"]
