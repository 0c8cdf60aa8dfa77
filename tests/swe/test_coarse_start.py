"""Coarse-to-fine start of a cold steady solve (breachflow.hydro.coarse_start): a lake at rest stays at
rest (exact: level everywhere, no velocity), the coarse surface is the mean of the wet cells' levels,
and bad settings are refused."""
import numpy as np
import pytest

from breachflow.errors import BreachflowError, InputError
from breachflow.hydro.coarse_start import CoarseStartSWE, coarse_surface
from breachflow.hydro.solvers import solvers
from breachflow.swe.domain import uniform_grid
from breachflow.hydro.far_field import coarse_domain
from breachflow.scenario import parse_scenario


def bumpy_lake():
    dom = uniform_grid(0, 40, 0, 20, 1.0, initial_surface=1.0)
    X, Y = np.meshgrid(dom.x, dom.y)
    dom.bed = 0.3 * np.sin(X / 5.0) * np.cos(Y / 4.0) + 0.2  # under the surface everywhere
    dom.manning = np.full(dom.shape, 0.03)
    return dom


def test_lake_at_rest_stays_at_rest_from_the_coarse_start():
    dom = bumpy_lake()
    solver = CoarseStartSWE(solvers.create("swe", tolerance=1e-6, t_max=20.0))
    out = solver.solve(dom)
    eta = out["bed_elevation"].values + out["depth"].values
    assert np.max(np.abs(eta - 1.0)) < 1e-12
    assert np.max(np.abs(out["u"].values)) < 1e-12 and np.max(np.abs(out["v"].values)) < 1e-12
    assert "coarse x2" in out.attrs["hydro_cold_start"] and solver.last_info["coarse_cells"] == 20 * 10


def test_coarse_surface_is_the_mean_over_the_wet_cells():
    eta = np.full((8, 8), np.nan)
    eta[:2, :2] = [[1.0, 2.0], [3.0, 4.0]]   # coarse cell (0, 0): mean 2.5
    eta[:2, 2:4] = [[0.5, 1.5], [np.nan, np.nan]]  # coarse cell (0, 1): 0.5 is below its bed, dry -> 1.5
    dom = uniform_grid(0, 8, 0, 8, 1.0, initial_surface=eta)
    dom.bed = np.zeros(dom.shape)
    dom.bed[0, 2] = 1.0
    dom.manning = np.full(dom.shape, 0.03)
    c, index = coarse_domain(dom, 2)
    assert c.shape == (4, 4)
    got = coarse_surface(dom, index, c)
    assert got[0, 0] == pytest.approx(2.5) and got[0, 1] == pytest.approx(1.5) and np.isnan(got[1, 1])


def test_bad_settings_are_refused():
    with pytest.raises(InputError):
        CoarseStartSWE(solvers.create("swe"), factor=1)
    with pytest.raises(BreachflowError) as err:
        parse_scenario('[scenario]\nname = "x"\n\n[hydro]\ncold_start = "warm"\n')
    assert "cold_start" in str(err.value) and ":5:" in str(err.value)
