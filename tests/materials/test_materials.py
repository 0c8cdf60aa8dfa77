"""Closure materials: EN 13383-1 gradings, unit materials, the registry and the volume-equivalent sphere."""
import math

import numpy as np
import pytest

from breachflow.errors import InputError
from breachflow.materials import MATERIALS, MaterialMix, get_material, nominal_diameter, sphere_diameter
from breachflow.materials.rock import LIMIT_FRACTIONS, STANDARD_GRADINGS, ganser_newton_cd
from breachflow.materials.units import BLOCK_TIPPING_MU_R, stabilized_soil_properties


@pytest.mark.parametrize("name", sorted(STANDARD_GRADINGS))
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_sampled_grading_meets_en13383_limits_and_mean_mass(name, seed):
    """Units drawn by number from each class: by mass < 5 % lighter than ELL, < 10 % lighter than NLL,
    > 70 % lighter than NUL, > 97 % lighter than EUL, and the mean unit mass M_em (total mass / number) in the
    standard's category-A range — the standard's own numbers, not the code's."""
    ell, nll, nul, eul, lo, hi = STANDARD_GRADINGS[name]
    m = get_material(name)
    s = m.sample_masses(np.random.default_rng(seed), 20000)
    frac = [s[s < x].sum() / s.sum() for x in (ell, nll, nul, eul)]
    assert frac[0] < LIMIT_FRACTIONS[0] and frac[1] < LIMIT_FRACTIONS[1], frac
    assert frac[2] > LIMIT_FRACTIONS[2] and frac[3] > LIMIT_FRACTIONS[3], frac
    assert lo <= s.mean() <= hi, (s.mean(), lo, hi)
    # the closed-form M_em of the cut curve agrees with the sample
    assert m.mean_unit_mass() == pytest.approx(s.mean(), rel=0.02)
    assert lo <= m.mean_unit_mass() <= hi


def test_grading_curve_is_the_rosin_rammler_curve_of_the_rock_manual():
    """M50 from the curve equals (D_n50)^3 rho_s; the cut curve passes through its two anchor points; the
    uncut curve is y = 1 - exp(-(M/lambda)^n) with the fitted parameters (independent formula)."""
    m = get_material("HMA_1000_3000")
    assert m.dn50 == pytest.approx((m.m50 / 2650.0) ** (1 / 3), rel=1e-12)
    assert float(m.mass_fraction_lighter(1000.0)) == pytest.approx(0.08, abs=1e-9)
    assert float(m.mass_fraction_lighter(3000.0)) == pytest.approx(0.75, abs=1e-9)
    assert float(m.mass_fraction_lighter(m.m50)) == pytest.approx(0.5, abs=1e-12)
    y = lambda M: 1 - math.exp(-(M / m.scale) ** m.n_rrm)  # noqa: E731
    raw = (y(2000.0) - y(650.0)) / (y(4500.0) - y(650.0))
    assert float(m.mass_fraction_lighter(2000.0)) == pytest.approx(raw, rel=1e-12)


def test_sample_is_seeded():
    m = get_material("HMA_3000_6000")
    a = m.sample_masses(np.random.default_rng([3, 7]), 50)
    b = m.sample_masses(np.random.default_rng([3, 7]), 50)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, m.sample_masses(np.random.default_rng([3, 8]), 50))


def test_nominal_and_sphere_diameters():
    # a 2650 kg unit at 2650 kg/m3 is 1 m3: D_n = 1 m, equal-volume sphere (6/pi)^(1/3) = 1.2407 m
    assert float(nominal_diameter(2650.0, 2650.0)) == pytest.approx(1.0)
    assert float(sphere_diameter(2650.0, 2650.0)) == pytest.approx(1.2407009817988, rel=1e-10)


def test_shape_drag_coefficients():
    """Ganser (1993): a sphere 0.4305; a cube (psi = 0.806) about 1.25 — within 20 % of Hoerner's face-on
    1.05 and above any sphere's subcritical 0.4–0.5; no drag crisis (a constant)."""
    assert ganser_newton_cd(1.0) == pytest.approx(0.4305)
    assert 1.05 < ganser_newton_cd(0.806) < 1.3
    assert get_material("concrete_cube").drag_coefficient == 1.05
    assert get_material("HMA_300_1000").drag_coefficient == pytest.approx(ganser_newton_cd(0.8))
    with pytest.raises(InputError):
        ganser_newton_cd(0.0)


def test_block_tipping_rolling_resistance():
    """mu_r of the equal-volume sphere that reproduces tipping a cube about an edge: a/(2R), R = a (3/4pi)^(1/3)."""
    a = 1.3
    R = a * (3 / (4 * math.pi)) ** (1 / 3)
    assert BLOCK_TIPPING_MU_R == pytest.approx(a / (2 * R), rel=1e-12)
    assert get_material("concrete_cube").rolling_friction == BLOCK_TIPPING_MU_R


def test_units_big_bag_cube_soil():
    bag = get_material("big_bag")
    assert bag.density == pytest.approx(0.6 * 2650 + 0.4 * 1000)
    s = bag.sample_masses(np.random.default_rng(0), 1000)
    assert s.min() >= 1000 and s.max() <= 10000
    cube = get_material({"name": "concrete_cube", "mass": 2500})
    assert cube.sample_masses(np.random.default_rng(0), 3).tolist() == [2500.0] * 3
    # side of a 2.5 t cube at 2400 kg/m3 is 1.0137 m
    assert float(nominal_diameter(2500.0, cube.density)) == pytest.approx((2500 / 2400) ** (1 / 3))
    with pytest.raises(InputError, match="mass_min"):
        get_material("big_bag", mass_min=5000, mass_max=1000)


def test_stabilized_soil_density_and_strength_by_hand():
    """rho_s of soil + 10 % cement: 1.1 / (1/2650 + 0.1/3150) = 2690.6; n = 1 - 1800/2690.6; rho_sat =
    1800 + 1000 n; granular strength at 10 % (top of 3–10 %) is 4.1 MPa; below the minimum is refused."""
    rho, q, n = stabilized_soil_properties("granular", 0.10, 1800.0)
    rho_s = 1.1 / (1 / 2650 + 0.1 / 3150)
    assert n == pytest.approx(1 - 1800 / rho_s, rel=1e-12)
    assert rho == pytest.approx(1800 + 1000 * (1 - 1800 / rho_s), rel=1e-12)
    assert q == pytest.approx(4.1e6)
    _, q_mid, _ = stabilized_soil_properties("silty", 0.10)
    assert q_mid == pytest.approx(1.7e6 + 0.5 * (3.4e6 - 1.7e6))
    with pytest.raises(InputError, match="below the clayey"):
        stabilized_soil_properties("clayey", 0.05)
    soil = get_material("stabilized_soil", soil="granular", cement_content=0.06, size=2.0)
    assert soil.sample_masses(np.random.default_rng(0), 1)[0] == pytest.approx(soil.density * 8.0)
    assert soil.strength > 0


def test_registry_lists_builtins_and_rejects_unknown():
    get_material("sphere")
    names = MATERIALS.available()
    for n in ("hma_1000_3000", "lma_60_300", "big_bag", "concrete_cube", "stabilized_soil", "sphere", "rock"):
        assert n in names
    with pytest.raises(InputError, match="unknown closure material"):
        get_material("granite_balls")


def test_mix_fractions_hold_by_tonnage():
    mix = MaterialMix(["HMA_1000_3000", "HMA_3000_6000"], [0.25, 0.75])
    mass, rho, idx = mix.sample(np.random.default_rng(4), 20000)
    t = np.array([mass[idx == k].sum() for k in range(2)]) / mass.sum()
    assert t == pytest.approx([0.25, 0.75], abs=0.02)
    # materials of different shape drag mix: each keeps its own (the DEM carries it per mass)
    mix = MaterialMix(["HMA_1000_3000", "concrete_cube"], [0.5, 0.5])
    units = mix.unit_parameters()
    assert [u["drag_coefficient"] for u in units] == [get_material("HMA_1000_3000").drag_coefficient, 1.05]
    assert [u["rolling_friction"] for u in units] == [get_material("HMA_1000_3000").rolling_friction,
                                                       get_material("concrete_cube").rolling_friction]
    assert mix.dem_parameters()["drag_coefficient"] is None  # no one value shared


def test_builtins_are_declared_as_entry_points():
    """Every built-in material (and the polder_leakage criterion) is declared in pyproject.toml and the entry
    point names the object the registry holds."""
    import importlib
    import tomllib
    from pathlib import Path

    from breachflow.cycle.criteria import criteria

    eps = tomllib.loads((Path(__file__).resolve().parents[2] / "pyproject.toml").read_text())["project"]["entry-points"]
    mats = eps["breachflow.materials"]
    get_material("sphere")  # loads the built-ins
    assert sorted(k.lower() for k in mats) == sorted(MATERIALS._items)
    for name, target in mats.items():
        mod, attr = target.split(":")
        assert getattr(importlib.import_module(mod), attr) is MATERIALS.get(name), name
    mod, attr = eps["breachflow.criteria"]["polder_leakage"].split(":")
    assert getattr(importlib.import_module(mod), attr) is criteria.get("polder_leakage")
