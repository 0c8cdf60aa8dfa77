"""Single-unit closure materials: big bags / sandbags, concrete cubes, stabilized-soil masses, and spheres.

Big bags (``big_bag``)
    Geotextile bags filled with sand, 1–10 t (the 2005 17th Street Canal closure dropped 1.4–9 t sandbags
    from helicopters). Bulk density of the saturated fill ``rho = (1 - n) rho_s + n rho_w`` (sand: ``rho_s`` =
    2650 kg/m³, ``n`` = 0.40: 1990 kg/m³); a filled bag is a rounded pillow, drag by Ganser's correlation
    at sphericity 0.9 (0.88); masses uniform between ``mass_min`` and ``mass_max``. A bag deforms into the
    bed instead of rolling: rolling resistance 0.8 (the tipping resistance of a cube, below).
Concrete cubes (``concrete_cube``)
    Cubes of side ``a`` (default 2.5 t at 2400 kg/m³, the Delta Works' closure blocks). Drag of a cube face-on
    1.05 (Hoerner 1965, *Fluid-Dynamic Drag*, Fig. 3-29). A block resting on a face does not roll: it tips
    about an edge when the moment exceeds ``W a / 2``; the rolling-resistance limit ``|M_r| <= mu_r R |F_N|``
    of the equal-volume sphere (``R = a (3/(4 pi))^(1/3)``) gives the same limit for ``mu_r = a / (2R) =
    0.806``.
Stabilized-soil masses (``stabilized_soil``)
    Local soil mixed with portland cement (SERRI report §1.3 item b). Cement content by dry mass of soil, the
    soil's group (``granular`` AASHTO A-1/A-2/A-3, ``silty`` A-4/A-5, ``clayey`` A-6/A-7) and the mix's dry
    density give the saturated density ``rho = rho_d + n rho_w`` with ``n = 1 - rho_d / rho_s``
    (``rho_s`` of the soil–cement solids from the two components' particle densities) and the unconfined
    compressive strength, interpolated linearly in the cement content over the group's usual range of cement
    contents and strengths (ACI 230.1R-09, *Report on Soil Cement*, Tables 3.1/4.1 after the PCA Soil-Cement
    Laboratory Handbook: granular 3–10 % cement, 7-day soaked 2.1–4.1 MPa; silty 7–13 %, 1.7–3.4 MPa;
    clayey 9–16 %, 1.4–2.8 MPa). A cement content below the group's lowest is refused (the mass would
    slake). Masses are blocks of a given size (default 2 m cubes); drag and tipping as a cube.
Spheres (``sphere``)
    The default: spheres of ``[placement] diameter`` and ``density`` with the ``[fluid]`` drag law and the
    ``[dem]`` friction and rolling friction, exactly as without a material.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..scenario.stone import DUMPED_POROSITY
from . import MATERIALS
from .rock import ganser_newton_cd

RHO_W = 1000.0
#: drag coefficient of a cube face-on to the flow (Hoerner 1965)
CUBE_FACE_CD = 1.05
#: rolling resistance of the equal-volume sphere that reproduces a block's tipping about an edge: a/(2R)
BLOCK_TIPPING_MU_R = 0.5 * (4.0 * math.pi / 3.0) ** (1.0 / 3.0)


@dataclass
class UnitMaterial:
    """A material of units whose masses are uniform between ``mass_min`` and ``mass_max`` (kg)."""

    name: str
    density: float
    mass_min: float
    mass_max: float
    drag_coefficient: float | None
    friction: float
    rolling_friction: float
    shape: str
    porosity: float = 0.40
    lift_coefficient: float | None = None
    strength: float | None = None  # unconfined compressive strength (Pa), where known
    added_mass_coefficient: float | None = None

    def __post_init__(self):
        if not (0 < self.mass_min <= self.mass_max) or not math.isfinite(self.mass_max):
            raise InputError(f"material {self.name}: need 0 < mass_min <= mass_max, got "
                             f"{self.mass_min}, {self.mass_max} kg")
        if not self.density > RHO_W:
            raise InputError(f"material {self.name}: density {self.density:g} kg/m3 does not sink in water")
        for k in ("friction", "rolling_friction"):
            if not getattr(self, k) >= 0:
                raise InputError(f"material {self.name}: {k} must be >= 0")

    def sample_masses(self, rng: np.random.Generator, n: int) -> np.ndarray:
        if self.mass_max > self.mass_min:
            return rng.uniform(self.mass_min, self.mass_max, n)
        return np.full(n, float(self.mass_min))


@MATERIALS.register("big_bag")
def big_bag(mass_min=1000.0, mass_max=10000.0, grain_density=2650.0, fill_porosity=0.40, sphericity=0.9,
            friction=0.5, rolling_friction=BLOCK_TIPPING_MU_R, added_mass_coefficient=None) -> UnitMaterial:
    """Sand-filled geotextile bags of ``mass_min``–``mass_max`` kg (module docstring)."""
    n = float(fill_porosity)
    if not 0 < n < 1:
        raise InputError(f"big_bag: fill_porosity must be in (0, 1), got {fill_porosity!r}")
    rho = (1 - n) * float(grain_density) + n * RHO_W
    return UnitMaterial("big_bag", rho, float(mass_min), float(mass_max), ganser_newton_cd(sphericity),
                        float(friction), float(rolling_friction), "bag", porosity=0.40,
                        added_mass_coefficient=added_mass_coefficient)


@MATERIALS.register("concrete_cube")
def concrete_cube(mass=2500.0, density=2400.0, friction=0.6, added_mass_coefficient=None) -> UnitMaterial:
    """Concrete cubes of *mass* kg (default 2.5 t, the Delta Works' blocks) at *density* kg/m³."""
    return UnitMaterial("concrete_cube", float(density), float(mass), float(mass), CUBE_FACE_CD, float(friction),
                        BLOCK_TIPPING_MU_R, "cube", porosity=0.45, added_mass_coefficient=added_mass_coefficient)


#: soil group → (cement content low, high (mass fraction of dry soil), 7-day soaked strength low, high (Pa))
SOIL_CEMENT = {
    "granular": (0.03, 0.10, 2.1e6, 4.1e6),
    "silty": (0.07, 0.13, 1.7e6, 3.4e6),
    "clayey": (0.09, 0.16, 1.4e6, 2.8e6),
}


def stabilized_soil_properties(soil: str, cement_content: float, dry_density: float = 1800.0,
                               soil_particle_density: float = 2650.0, cement_particle_density: float = 3150.0):
    """``(saturated density kg/m³, unconfined compressive strength Pa, porosity)`` of a soil–cement mass
    (module docstring). *cement_content* is the cement's mass over the dry soil's mass."""
    if soil not in SOIL_CEMENT:
        raise InputError(f"stabilized_soil: soil must be one of {sorted(SOIL_CEMENT)}, got {soil!r}")
    c = float(cement_content)
    c_lo, c_hi, q_lo, q_hi = SOIL_CEMENT[soil]
    if not c_lo <= c <= 0.5:
        raise InputError(f"stabilized_soil: cement_content {c:g} is below the {soil} soils' usual minimum {c_lo:g} "
                         f"(ACI 230.1R): the mass would slake in the flow")
    # particle density of the solids: mass-weighted harmonic mean of soil and cement
    rho_s = (1.0 + c) / (1.0 / float(soil_particle_density) + c / float(cement_particle_density))
    rho_d = float(dry_density)
    if not 0 < rho_d < rho_s:
        raise InputError(f"stabilized_soil: dry_density {rho_d:g} must be below the solids' density {rho_s:.0f} kg/m3")
    n = 1.0 - rho_d / rho_s
    rho_sat = rho_d + n * RHO_W
    q = q_lo + (q_hi - q_lo) * min((c - c_lo) / (c_hi - c_lo), 1.0)
    return rho_sat, q, n


@MATERIALS.register("stabilized_soil")
def stabilized_soil(soil="granular", cement_content=0.06, dry_density=1800.0, size=2.0,
                    soil_particle_density=2650.0, friction=0.6, added_mass_coefficient=None) -> UnitMaterial:
    """Soil–cement blocks of side *size* (m) from a *soil* group and *cement_content* (module docstring)."""
    rho, q, _ = stabilized_soil_properties(soil, cement_content, dry_density, soil_particle_density)
    a = float(size)
    if not a > 0:
        raise InputError(f"stabilized_soil: size must be > 0 m, got {size!r}")
    m = rho * a ** 3
    return UnitMaterial("stabilized_soil", rho, m, m, CUBE_FACE_CD, float(friction), BLOCK_TIPPING_MU_R, "block",
                        porosity=0.45, strength=q, added_mass_coefficient=added_mass_coefficient)


@dataclass
class SphereMaterial:
    """Spheres of diameter uniform in ``diameter`` (m) and density uniform in ``density`` (kg/m³): the closure
    run's masses without a material. ``drag_coefficient`` None: the ``[fluid]`` drag law applies; friction
    and rolling friction None: the ``[dem]`` values."""

    diameter: tuple = (1.0, 1.0)
    density_range: tuple = (2650.0, 2650.0)
    name: str = "sphere"
    drag_coefficient: float | None = None
    lift_coefficient: float | None = None
    added_mass_coefficient: float | None = None
    friction: float | None = None
    rolling_friction: float | None = None
    shape: str = "sphere"
    porosity: float = DUMPED_POROSITY

    @property
    def density(self) -> float:
        return 0.5 * (self.density_range[0] + self.density_range[1])

    def sample_masses(self, rng: np.random.Generator, n: int) -> np.ndarray:
        d = rng.uniform(*self.diameter, n) if self.diameter[1] > self.diameter[0] else np.full(n, self.diameter[0])
        return self.density * np.pi / 6.0 * d ** 3


MATERIALS.register("sphere", SphereMaterial)
