"""[placement] material: the closure cycle creates the units of a closure material as volume-equivalent spheres
and gives the DEM and the fluid forces the material's friction, rolling resistance and shape drag."""
import math

import numpy as np
import pytest

from breachflow.cycle.config import closure_setup
from breachflow.cycle.placement import PlacementPlan
from breachflow.errors import BreachflowError, InputError
from breachflow.materials import get_material
from breachflow.scenario.config import parse_scenario

SURF = lambda x, y: np.zeros_like(np.asarray(x, float))  # noqa: E731


def test_release_draws_units_from_the_grading_as_equal_volume_spheres():
    plan = PlacementPlan.from_config({"material": "HMA_1000_3000", "batch": 6})
    rock = get_material("HMA_1000_3000")
    k = (6 / math.pi) ** (1 / 3)
    masses = []
    for g in range(1, 40):
        rel = plan.release(g, 3, SURF)
        m = rel.density * math.pi / 6 * (2 * rel.radius) ** 3
        masses.append(m)
        assert np.all(rel.density == 2650.0)
    m = np.concatenate(masses)
    assert m.min() >= rock.ell * (1 - 1e-9) and m.max() <= rock.eul * (1 + 1e-9)
    # the same cycle and seed give the same units (a resumed run places what an uninterrupted one would)
    np.testing.assert_array_equal(plan.release(5, 3, SURF).radius, plan.release(5, 3, SURF).radius)
    # the plan's diameter range spans the DEM spheres (wall offsets, breach area)
    assert k * (rock.ell / 2650) ** (1 / 3) <= plan.diameter[0] < plan.diameter[1] <= k * (rock.eul / 2650) ** (1 / 3)


def test_spheres_stay_as_before_without_a_material():
    a = PlacementPlan.from_config({"diameter": ["1 m", "2 m"], "batch": 3})
    b = PlacementPlan.from_config({"diameter": ["1 m", "2 m"], "batch": 3, "material": "sphere"})
    ra, rb = a.release(2, 7, SURF), b.release(2, 7, SURF)
    np.testing.assert_array_equal(ra.radius, rb.radius)
    np.testing.assert_array_equal(ra.pos, rb.pos)
    # and equal to the uniform draws written out here
    rng = np.random.default_rng([7, 2])
    np.testing.assert_array_equal(2 * ra.radius, rng.uniform(1.0, 2.0, 3))
    assert a.dem_parameters() is None


def test_material_with_sphere_keys_is_refused():
    with pytest.raises(InputError, match="leave out placement.diameter"):
        PlacementPlan.from_config({"material": "HMA_1000_3000", "diameter": "1 m"})
    with pytest.raises(InputError, match="one fraction per material"):
        PlacementPlan.from_config({"material": ["HMA_1000_3000", "HMA_3000_6000"], "fractions": [1.0]})
    with pytest.raises(InputError, match="unknown closure material"):
        PlacementPlan.from_config({"material": "HMA_2000_4000"})


def test_scenario_material_reaches_the_dem_and_the_drag_law():
    s = closure_setup(parse_scenario('[placement]\nmaterial = "HMA_3000_6000"\nbatch = 2\n'))
    rock = get_material("HMA_3000_6000")
    assert s.dem.material.friction == rock.friction
    assert s.dem.material.rolling_friction == rock.rolling_friction
    assert s.dem.drag_law.name == "constant" and s.dem.drag_law.value == rock.drag_coefficient
    assert s.metadata["material"] == "HMA_3000_6000"
    # an explicit [dem] key wins over the material's
    s2 = closure_setup(parse_scenario('[placement]\nmaterial = "concrete_cube"\n[dem]\nrolling_friction = 0.2\n'))
    assert s2.dem.material.rolling_friction == 0.2
    assert s2.dem.drag_law.value == 1.05
    # without a material: the [fluid] drag law by name, the [dem] defaults
    s3 = closure_setup(parse_scenario('[placement]\ndiameter = "1.5 m"\n'))
    assert s3.dem.drag_law == "report" and s3.dem.material.rolling_friction == 0.3


def test_scenario_error_names_the_key():
    with pytest.raises(BreachflowError, match=r"\[placement\].*leave out placement.diameter"):
        parse_scenario('[placement]\nmaterial = "HMA_1000_3000"\ndiameter = "2 m"\n')
