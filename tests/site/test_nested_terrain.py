"""A nested grid takes its terrain from the finest source, not from the coarse grid's bed.

The breach of a preset scene is analytic (:func:`breachflow.swe.domain.levee_bed`): a nested 1 m grid must
hold the breach's width and floor exactly, whatever the coarse grid (on the typical breach's 4 m grid the breach
ends fall 1.5 m off the cell faces, and the coarse bed interpolated smears the walls over two columns). And the
flow on a nested grid must be the flow on a uniform grid of the same cells: the nested 1 m breach discharge and
gap speed within 2 % of the uniform 1 m grid's (the verdict check's tolerance). Expected values: the scene's
own dimensions and the uniform grid's solution, never this code's earlier output.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from breachflow.field.snapshot import grid_snapshot
from breachflow.hydro.nested import breach_box, nested_domain
from breachflow.scenario.geometry import BreachGeometry, typical_breach
from breachflow.swe.domain import breach_domain, breach_terrain, levee_bed

ROOT = Path(__file__).resolve().parents[2]


def _at_rest(dom):
    """A regional snapshot of *dom*: its initial water at rest (the flood side at the source level)."""
    h = np.where(np.isfinite(dom.initial_surface), np.maximum(np.nan_to_num(dom.initial_surface) - dom.bed, 0.0), 0.0)
    z = np.zeros(dom.shape)
    return grid_snapshot(dom.x, dom.y, dom.bed, h, z, z, obstacle=dom.obstacle)


def _scene(wall_slope):
    sc = typical_breach()
    if wall_slope:
        from dataclasses import replace

        sc = replace(sc, breach=BreachGeometry(length=61.0, depth=7.6, wall_slope=wall_slope))
    return sc


@pytest.mark.parametrize("coarse", [4.0, 5.0, 8.0])
@pytest.mark.parametrize("wall_slope", [0.0, 0.5])
def test_nested_grid_holds_the_analytic_breach_width_and_floor(coarse, wall_slope):
    scene = _scene(wall_slope)
    regional = _at_rest(breach_domain(scene, coarse))
    box, dx = breach_box(0.0, 0.0, 61.0, 1.0)
    dom, (h, _, _) = nested_domain(regional, box, dx, terrain=breach_terrain(scene))
    assert dx == 1.0
    X, Y = np.meshgrid(dom.x, dom.y)
    # the bed is the scene's at every open cell (the breach floor at the ground, 30.5 m, exactly)
    open_ = ~dom.obstacle
    np.testing.assert_array_equal(dom.bed[open_], levee_bed(scene, X, Y)[open_])
    floor = np.abs(X) < 0.5 * scene.breach.bottom_width
    assert np.all(dom.bed[floor & (np.abs(Y) < 30.0)] == 30.5)
    # on every row of the levee footprint the opening is the breach's 61 m: 61 open cells, ends on faces
    foot = np.abs(dom.y) < 31.9  # the levee's footprint: crown 3 m + 2 x 7.6 m x 4 (1V:4H)
    assert foot.sum() == 64
    np.testing.assert_array_equal(open_[foot].sum(axis=1), 61)
    assert np.all(open_[foot][:, np.abs(dom.x) < 30.5])
    # the initial water is the regional surface over the local bed: the flood side at the source level
    flood = (Y < -40.0) & open_
    np.testing.assert_allclose((dom.bed + h)[flood], 38.1, atol=0.1)


def test_without_the_terrain_the_coarse_bed_smears_the_breach():
    """The reason for the terrain: the coarse 4 m bed interpolated does not hold the 61 m opening."""
    scene = typical_breach()
    regional = _at_rest(breach_domain(scene, 4.0))
    box, dx = breach_box(0.0, 0.0, 61.0, 1.0)
    dom, _ = nested_domain(regional, box, dx)
    j = int(np.argmin(np.abs(dom.y)))
    open_floor = (~dom.obstacle[j]) & (dom.bed[j] < 30.5 + 1e-6)
    assert open_floor.sum() * dx != 61.0


def _first_solve(text):
    from breachflow.cycle.config import closure_setup
    from breachflow.cycle.criteria import gap_section_speeds, section_discharge
    from breachflow.scenario import load_scenario

    setup = closure_setup(load_scenario(text))
    snap = setup.solver.solve(setup.domain)
    return section_discharge(snap, setup.breach_x, setup.levee_y), gap_section_speeds(snap, setup.breach_x, setup.levee_y)[1]


@pytest.fixture(scope="module")
def uniform_1m(tmp_path_factory):
    return _scenario_solve(tmp_path_factory.mktemp("u1"), "1", None)


def _scenario_solve(d, res, refine):
    text = (ROOT / "src" / "breachflow" / "data" / "closure_default.toml").read_text()
    grid = f'resolution = "{res} m"' + (f'\nrefine = "{refine} m"' if refine else "")
    path = d / "s.toml"
    path.write_text(re.sub(r"^resolution = .*$", grid, text, count=1, flags=re.M))
    return _first_solve(path)


@pytest.mark.parametrize("coarse", ["2", "4"])
def test_nested_1m_discharge_and_gap_speed_agree_with_uniform_1m(coarse, uniform_1m, tmp_path):
    """The embedded default scene (12 m breach, 3 m levee): nested 1 m in a 2 m or 4 m solve against
    the uniform 1 m grid, within the verdict check's 2 %."""
    q1, s1 = uniform_1m
    qn, sn = _scenario_solve(tmp_path, coarse, "1")
    assert abs(qn / q1 - 1) <= 0.02, (qn, q1)
    assert abs(sn / s1 - 1) <= 0.02, (sn, s1)


def test_a_site_nested_grid_takes_the_terrain_file_with_the_breach_cut(tmp_path):
    """The example site (12 m breach cut to 2.0 m in a GeoTIFF levee) at 5 m cells with a nested 0.5 m grid:
    on the levee line the nested grid's floor is the breach bottom over exactly the breach's 12 m (24 cells),
    where the coarse 5 m bed interpolated holds it over no cell's full width."""
    from breachflow.cycle.config import closure_setup
    from breachflow.scenario import load_scenario

    from .conftest import site_toml

    path = site_toml(tmp_path, replace={"resolution": '"5 m"', "t_max_initial": '"60 s"'},
                     extra_site="")
    text = path.read_text().replace('resolution = "5 m"', 'resolution = "5 m"\nrefine = "0.5 m"')
    path.write_text(text)
    setup = closure_setup(load_scenario(path))
    dom = setup.domain
    assert dom.dx == pytest.approx(0.5)
    j = int(np.argmin(np.abs(dom.y - setup.levee_y)))
    floor = np.isclose(dom.bed[j], 2.0, atol=1e-9) & ~dom.obstacle[j]
    assert floor.sum() == 24
    xs = dom.x[floor]
    assert xs.min() - 0.25 == pytest.approx(setup.breach_x[0]) and xs.max() + 0.25 == pytest.approx(setup.breach_x[1])
    coarse = setup.solver.regional
    from breachflow.hydro.nested import nested_domain

    smeared, _ = nested_domain(coarse, setup.solver.box, 0.5)
    assert not (np.isclose(smeared.bed[j], 2.0, atol=1e-9) & ~smeared.obstacle[j]).sum() == 24
