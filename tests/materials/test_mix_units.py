"""A mix of closure materials in one run: every mass carries its own material's drag coefficient, friction and
rolling resistance (per particle in the DEM state and the fluid-force kernels), kept across a resume; a run of
one material is bit for bit what it was with one run-wide drag law and material.

The thresholds are checked against two independent references: Izbash's band for rock,
0.86 sqrt(2 g Delta D_n) <= u_c <= 1.2 sqrt(2 g Delta D_n) (Izbash & Khaldre 1970; CIRIA Rock Manual 2007
§5.2.1.2), and a separate run of each material alone (breachflow.studies.stability.critical_velocity), whose
threshold the unit must reproduce inside the mix."""
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from breachflow.cycle.config import closure_setup
from breachflow.cycle.driver import ClosureRun
from breachflow.dem import Material
from breachflow.fluid.drag import DRAG_LAWS
from breachflow.io import RunDirectory
from breachflow.materials import get_material
from breachflow.scenario.config import parse_scenario
from breachflow.scenario.toml import scenario_with
from breachflow.studies.stability import critical_velocities, units_move

G = 9.80665
EXPOSED, EMBEDDED = 0.86, 1.20
K_SPHERE = (6 / math.pi) ** (1 / 3)  # DEM sphere diameter / nominal diameter


def _unit(name, dn):
    m = get_material(name)
    ds = K_SPHERE * dn
    mat = Material(density=m.density, kn=2.0e7 * (ds / 2.0) ** 2, friction=m.friction,
                   rolling_friction=m.rolling_friction)
    return m, {"D": ds, "material": mat, "drag_coefficient": m.drag_coefficient}


def _alone(m, unit, angle):
    """The unit's threshold in a run of its material alone: one drag law for the run (constant, its C_D)."""
    a = math.radians(angle)
    return _critical_alone(unit, m.drag_coefficient, m.density, (math.cos(a), math.sin(a)))


def _critical_alone(unit, cd, density, direction):
    from breachflow.studies.stability import stone_moves

    kw = dict(velocity_profile="uniform", drag_law=DRAG_LAWS.create("constant", value=cd), density=density,
              material=unit["material"], direction=direction)
    hi = 5.0 * 1.2 * math.sqrt(2 * G * (density - 1000.0) / 1000.0 * unit["D"] / K_SPHERE)
    assert stone_moves(hi, unit["D"], 10.0, **kw)
    lo = 0.0
    while hi - lo > 0.01 * hi:
        mid = 0.5 * (lo + hi)
        if stone_moves(mid, unit["D"], 10.0, **kw):
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi)


def _izbash(m, dn):
    return math.sqrt(2 * G * (m.density - 1000.0) / 1000.0 * dn)


@pytest.mark.parametrize("other, dn_rock, dn_other, angle", [
    ("big_bag", 1.0, 1.0, 0.0),            # rock and big bags of one size, flow along the pocket
    pytest.param("concrete_cube", 1.0, 0.6, 30.0, marks=pytest.mark.slow),  # different sizes, over the saddle
    pytest.param("big_bag", 2.0, 0.7, 90.0, marks=pytest.mark.slow),
])
def test_each_unit_of_a_mix_moves_at_its_own_materials_threshold(other, dn_rock, dn_other, angle):
    rock, ur = _unit("HMA_1000_3000", dn_rock)
    oth, uo = _unit(other, dn_other)
    a = math.radians(angle)
    # the scene's own drag law is the smooth sphere's (report): only the units' own coefficients act
    mixed = critical_velocities([ur, uo], 10.0, direction=(math.cos(a), math.sin(a)))
    alone = [_alone(rock, ur, angle), _alone(oth, uo, angle)]
    # inside the mix, each unit reproduces its material's run alone (two bisections to 1 %)
    assert mixed == pytest.approx(alone, rel=0.025)
    # the rock, inside the mix, within Izbash's band
    assert EXPOSED <= mixed[0] / _izbash(rock, dn_rock) <= EMBEDDED
    # and the two materials' thresholds are told apart (the check is not blind to the material)
    assert abs(mixed[1] / mixed[0] - 1.0) > 0.1


def test_one_drag_law_for_all_would_move_the_bags_at_the_wrong_speed():
    """The check can fail: with the rock's drag for every mass (one drag law per run, as a mix had before),
    the bag's threshold is off its own material's by more than the tolerance above."""
    rock, ur = _unit("HMA_1000_3000", 1.0)
    bag, ub = _unit("big_bag", 1.0)
    u = 0.9 * _alone(bag, ub, 0.0)  # 10 % below the bag's own threshold
    one_law = DRAG_LAWS.create("constant", value=rock.drag_coefficient)
    assert units_move(u, [dict(ur, drag_coefficient=None), dict(ub, drag_coefficient=None)], 10.0,
                      drag_law=one_law) == [False, True]  # the bag, with the rock's drag, moves too early
    assert units_move(u, [ur, ub], 10.0) == [False, False]  # with its own, it stays


# ------------------------------------------------------------------------------------------ closure runs
CI_CLOSURE = (Path(__file__).resolve().parents[1] / "data" / "ci_closure.toml").read_text()


def _scene(material, fractions=None):
    ch = {"placement.diameter": None, "placement.material": material, "criteria.max_cycles": 2}
    if fractions is not None:
        ch["placement.fractions"] = fractions
    return scenario_with(CI_CLOSURE, ch)


def _same_files(a: RunDirectory, b: RunDirectory, cycles):
    for g in cycles:
        with xr.open_dataset(a.cycle_path(g)) as da, xr.open_dataset(b.cycle_path(g)) as db:
            assert set(da.variables) == set(db.variables)
            for name in da.variables:
                np.testing.assert_array_equal(da[name].values, db[name].values, err_msg=name)
        ra, rb = a.load_restart(g), b.load_restart(g)
        for k in ("dem.state.pos", "dem.state.vel", "dem.state.omega", "dem.state.friction",
                  "dem.state.rolling_friction"):
            np.testing.assert_array_equal(ra[k], rb[k], err_msg=k)


def test_one_material_run_is_bit_identical_to_the_run_wide_drag_law(tmp_path):
    """One material: its masses carry its values per particle; the run equals, bit for bit, the run in which
    every mass takes the run-wide material and the constant drag law of the material's C_D (the path of a run
    of one material before the values were per particle)."""
    text = _scene("HMA_6000_10000")
    setup = closure_setup(parse_scenario(text))
    assert len(setup.dem.units) == 1 and setup.dem.drag_law.value == setup.dem.units[0]["drag_coefficient"]
    ClosureRun(setup, tmp_path / "own", text).run()
    old = closure_setup(parse_scenario(text))
    old.dem = replace(old.dem, units=())
    ClosureRun(old, tmp_path / "run_wide", text).run()
    a, b = RunDirectory(tmp_path / "own"), RunDirectory(tmp_path / "run_wide")
    assert a.completed_cycles() == b.completed_cycles() == [1, 2]
    _same_files(a, b, (1, 2))
    st = a.load_restart(2)
    placed = np.isfinite(st["dem.state.drag_coefficient"])
    assert placed.sum() == 6  # 3 masses a cycle, each with the rock's own C_D
    assert np.all(st["dem.state.drag_coefficient"][placed] == get_material("HMA_6000_10000").drag_coefficient)


class Crash(Exception):
    pass


def test_mix_run_keeps_each_mass_material_and_resumes_identically(tmp_path):
    text = _scene(["HMA_6000_10000", "big_bag"], [0.5, 0.5])
    setup = closure_setup(parse_scenario(text))
    rock, bag = get_material("HMA_6000_10000"), get_material("big_bag")
    assert [u["drag_coefficient"] for u in setup.dem.units] == [rock.drag_coefficient, bag.drag_coefficient]
    assert setup.dem.drag_law == "report"  # no value shared: the masses carry theirs
    ClosureRun(setup, tmp_path / "full", text).run()
    full = RunDirectory(tmp_path / "full")
    st = full.load_restart(2)
    rho, cd = st["dem.state.density"], st["dem.state.drag_coefficient"]
    mu_r, fr = st["dem.state.rolling_friction"], st["dem.state.friction"]
    is_rock, is_bag = rho == rock.density, rho == bag.density
    assert is_rock.any() and is_bag.any() and (is_rock | is_bag).all()
    assert np.all(cd[is_rock] == rock.drag_coefficient) and np.all(cd[is_bag] == bag.drag_coefficient)
    assert np.all(mu_r[is_rock] == rock.rolling_friction) and np.all(mu_r[is_bag] == bag.rolling_friction)
    assert np.all(fr[is_rock] == rock.friction) and np.all(fr[is_bag] == bag.friction)

    def crash_after_first(rep):
        if rep.cycle == 1:
            raise Crash()

    with pytest.raises(Crash):
        ClosureRun(closure_setup(parse_scenario(text)), tmp_path / "resumed", text, progress=crash_after_first).run()
    ClosureRun(closure_setup(parse_scenario(text)), tmp_path / "resumed", text, resume=True).run()
    resumed = RunDirectory(tmp_path / "resumed")
    _same_files(full, resumed, (1, 2))
    np.testing.assert_array_equal(st["dem.state.drag_coefficient"],
                                  resumed.load_restart(2)["dem.state.drag_coefficient"])


def test_a_dem_state_saved_before_the_per_particle_coefficients_loads_with_the_run_values():
    """A restart record without ``state.drag_coefficient`` / ``state.lift_coefficient`` (written before they
    existed) continues with every particle on the run's drag law, exactly as one saved with them unset."""
    from breachflow.dem import DemSimulation
    from breachflow.fluid.forces import FluidForces
    from breachflow.fluid.field import UniformWater

    def sim_of(state=None):
        fluid = FluidForces(UniformWater(surface=5.0, u=1.0, v=0.0, bed=0.0), drag_law="report", air=None)
        if state is not None:
            return DemSimulation.from_state(state, models=[fluid], sleeping=False)
        s = DemSimulation(models=[fluid], sleeping=False)
        s.add_particles([[0.0, 0.0, 2.0], [3.0, 0.0, 2.5]], 0.5, Material(density=2650.0, kn=1e7))
        return s

    a = sim_of()
    a.step(20)
    saved = a.save_state()
    old = {k: v for k, v in saved.items() if k not in ("state.drag_coefficient", "state.lift_coefficient")}
    b, c = sim_of(saved), sim_of(old)
    assert np.isnan(c.state.drag_coefficient).all() and np.isnan(c.state.lift_coefficient).all()
    b.step(50)
    c.step(50)
    np.testing.assert_array_equal(b.state.pos, c.state.pos)
    np.testing.assert_array_equal(b.state.vel, c.state.vel)


def test_bad_per_particle_coefficients_are_refused():
    from breachflow.dem import DemSimulation
    from breachflow.errors import InputError

    sim = DemSimulation()
    with pytest.raises(InputError, match="drag_coefficient must be > 0"):
        sim.add_particles([[0.0, 0.0, 1.0]], 0.5, drag_coefficient=-1.0)
    with pytest.raises(InputError, match="lift_coefficient must be >= 0"):
        sim.add_particles([[0.0, 0.0, 1.0]], 0.5, lift_coefficient=-0.2)
