"""``solver = "nested"`` in a regional model given as ESRI ASCII grids (issue 13).

A raster has no no-flow cells: the intact levee that the regional model held dry (a mesh hole, an
obstacle cell) is dry terrain with NODATA depth in the ``.asc`` files, and the local model must not
open it to the flood (:mod:`breachflow.hydro.regional_grid`). The "user's grids" are the package's own
steady state re-sampled onto a grid whose spacing and origin match neither our solver grid nor the
local one (finer and coarser), the levee cells dry, written with ``write_esri`` (RAS Mapper / GDAL
layout: dry = NODATA) and read back as ``breachflow run`` reads them."""
import json
import re
import time
from dataclasses import replace

import numpy as np
import pytest
import xarray as xr

from breachflow.cycle.config import closure_setup, demo_breach
from breachflow.cycle.main import run_closure
from breachflow.field.crs import local_crs_wkt
from breachflow.io import write_esri
from breachflow.hydro.nested import NestedSolver, fill_obstacles
from breachflow.hydro.regional_grid import infer_no_flow, with_no_flow
from breachflow.field.sampling import FieldSampler
from breachflow.field.snapshot import grid_snapshot, set_crs
from breachflow.scenario.config import load_scenario

from .test_nested import (NESTED_SCENARIO, TYPICAL_NESTED, _closure_print, check_consistency,  # noqa: F401
                          demo_grid_wide, typical_grid)


def regrid(grid, spacing: float, ox: float, oy: float) -> xr.Dataset:
    """*grid* (a solver steady state with its levee as obstacle cells) re-sampled onto cells of *spacing*
    whose centres lie at ``ox + k spacing``, ``oy + l spacing`` inside its extent, as a raster export has
    it: bilinear in the open flow, the levee (cells whose centre lies in an obstacle cell) as terrain with
    depth 0 (dry). No obstacle mask."""
    dx, dy = float(grid.x[1] - grid.x[0]), float(grid.y[1] - grid.y[0])
    x0, x1 = float(grid.x[0]) - dx / 2, float(grid.x[-1]) + dx / 2
    y0, y1 = float(grid.y[0]) - dy / 2, float(grid.y[-1]) + dy / 2
    xs = np.arange(np.ceil((x0 - ox) / spacing + 0.5), np.floor((x1 - ox) / spacing - 0.5) + 1) * spacing + ox
    ys = np.arange(np.ceil((y0 - oy) / spacing + 0.5), np.floor((y1 - oy) / spacing - 0.5) + 1) * spacing + oy
    X, Y = np.meshgrid(xs, ys)
    s = FieldSampler(fill_obstacles(grid), "bilinear").sample(X.ravel(), Y.ravel())
    i = np.clip(((X - x0) / dx).astype(int), 0, grid.x.size - 1)
    j = np.clip(((Y - y0) / dy).astype(int), 0, grid.y.size - 1)
    ob = grid["obstacle"].values.astype(bool)[j, i]

    def open_(a):
        return np.where(ob, 0.0, np.nan_to_num(a.reshape(X.shape)))

    bed = np.where(ob, grid["bed_elevation"].values[j, i], s.bed.reshape(X.shape))
    return grid_snapshot(xs, ys, bed, open_(s.depth), open_(s.u), open_(s.v), source="test: re-sampled steady state")


def esri_files(grid, folder, spacing, ox, oy):
    """The re-sampled steady state as ``PREFIX_{depth,wse,terrain,vx,vy}.asc`` + ``.prj`` (metres)."""
    return write_esri(set_crs(regrid(grid, spacing, ox, oy), local_crs_wkt()), folder / "regional")


def test_infer_no_flow_marks_the_dry_cells_the_water_would_flood():
    """A hand-made cross-section through a levee (rows = along it): flood-side pool at level 5, the
    levee's flood slope (beds 2, 3, 4: below the pool) dry → no-flow, also the ones with no wet
    neighbour; its crest (6) and a dry knoll in the pool (7) stay ground; the protected slope (4, 3)
    stays ground above the polder water (level 2.5) except the cell at 2.4 (2.5 − 2.4 > 1 cm) and not
    the cell at 2.495 (within the 1 cm tolerance); a low dry cell (1) ringed by high ground is not
    reached. Meshes and grids with an obstacle mask are left alone."""
    bed = np.array([0, 0, 7, 0, 2, 3, 4, 6, 4, 3, 2.4, 0, 0], float)
    lvl = np.array([5, 5, np.nan, 5, np.nan, np.nan, np.nan, np.nan, np.nan, np.nan, np.nan, 2.5, 2.5])
    want = np.array([0, 0, 0, 0, 1, 1, 1, 0, 0, 0, 1, 0, 0], bool)
    B = np.tile(bed, (4, 1))
    H = np.tile(np.where(np.isnan(lvl), 0.0, lvl - bed), (4, 1))
    W = np.tile(want, (4, 1))
    B[3, 10] = 2.495  # within the tolerance: ground
    W[3, 10] = False
    x, y = np.arange(B.shape[1]) * 2.0, np.arange(B.shape[0]) * 2.0
    g = grid_snapshot(x, y, B, H, np.zeros_like(B), np.zeros_like(B))
    np.testing.assert_array_equal(infer_no_flow(g), W)
    out = with_no_flow(g)
    np.testing.assert_array_equal(out["obstacle"].values.astype(bool), W)
    assert "obstacle_inferred" in out.attrs and "obstacle" not in g
    # a pocket: a low dry cell enclosed by high dry ground, beside the pool, is never reached
    B2 = np.full((5, 5), 9.0)
    B2[2, 2] = 1.0
    B2[:, 0] = 0.0
    H2 = np.zeros_like(B2)
    H2[:, 0] = 5.0
    g2 = grid_snapshot(np.arange(5.0), np.arange(5.0), B2, H2, np.zeros_like(B2), np.zeros_like(B2))
    assert not infer_no_flow(g2).any() and with_no_flow(g2) is g2
    g3 = grid_snapshot(x, y, B, H, np.zeros_like(B), np.zeros_like(B), obstacle=np.zeros(B.shape, bool))
    assert with_no_flow(g3) is g3  # the model's own mask is kept


# one spacing and offset in the default run; the others run with --slow
@pytest.mark.parametrize("spacing,ox,oy", [(1.9, 0.37, 0.83), pytest.param(3.1, 1.37, -0.61, marks=pytest.mark.slow),
                                           pytest.param(4.6, -0.83, 2.11, marks=pytest.mark.slow)])
def test_nested_from_esri_grids_reproduces_the_field_near_the_breach(typical_grid, tmp_path, spacing, ox, oy):
    """The typical breach's steady state as ESRI grids at a spacing and origin that match neither the
    4 m solver grid nor the local 4.07 m grid (finer and coarser), listed in ``[hydro] snapshots`` and
    set up as ``breachflow run`` does: with no masses the local re-solve keeps the ingested field within
    2 B of the breach (mean |Δ speed| and |Δ depth| within 5 % of the mean speed and depth there), and
    no water crosses the intact levee (before the dry levee was read as no-flow: 11.7–14.5 %, the whole
    levee overflowing)."""
    scene, grid = typical_grid
    files = esri_files(grid, tmp_path, spacing, ox, oy)
    sc = tmp_path / "nested.toml"
    sc.write_text(TYPICAL_NESTED.format(files=", ".join(f'"{p.name}"' for p in files if p.suffix == ".asc")))
    ns = closure_setup(load_scenario(sc)).solver
    assert isinstance(ns, NestedSolver) and ns.regional.attrs["breachflow_reader"] == "asc"
    assert float(ns.regional.x[1] - ns.regional.x[0]) == pytest.approx(spacing)
    local = ns.solve()
    B = scene.breach.length
    check_consistency(("consistency esri", spacing, ox, oy), local, ns.regional, grid, B)
    # the intact levee stays dry: no local cell on its crest line (y = 0) beyond the breach walls holds water
    X, Y = np.meshgrid(local.x.values, local.y.values)
    crest = (np.abs(Y) < 0.6 * float(local.y[1] - local.y[0])) & (np.abs(X) > 0.5 * B + 8.0)
    assert crest.sum() > 50
    assert float(np.max(np.where(crest, local.depth.values, 0.0))) < 0.01


def test_nested_closure_from_esri_grids(demo_grid_wide, tmp_path):
    """``breachflow ingest`` of the scaled breach's steady state as ESRI grids (0.83 m cells offset from
    the 1 m grid; ``--units m``, no ``.prj``), then ``breachflow run`` with ``solver = "nested"`` on the
    ingested NetCDF: the local model re-solved with the pile each cycle shuts the breach."""
    from typer.testing import CliRunner

    from breachflow.cli import app

    files = [p for p in write_esri(regrid(demo_grid_wide, 0.83, 0.31, -0.27), tmp_path / "demo") if p.suffix == ".asc"]
    r = CliRunner().invoke(app, ["ingest", *map(str, files), "--units", "m", "-o", str(tmp_path / "regional.nc")])
    assert r.exit_code == 0, r.output
    text = NESTED_SCENARIO.format(files='"regional.nc"')
    for key in ("levee_length_each_side", "flood_side_extent", "protected_side_extent"):
        text = re.sub(rf'{key} = "\d+ m"', f'{key} = "36 m"', text)
    scen = tmp_path / "nested.toml"
    scen.write_text(text)
    t0 = time.process_time()
    res = run_closure(scen, tmp_path / "run", plots=False)
    _closure_print("esri", res, time.process_time() - t0)
    man = json.loads((tmp_path / "run" / "manifest.json").read_text())
    assert man["metadata"]["hydro_mode"] == "nested"
    assert res.closed, [(r.cycle, r.breach_discharge, r.max_speed) for r in res.reports]
    q0 = man["metadata"]["initial"]["breach_discharge"]
    assert q0 > 20.0 and abs(res.reports[-1].breach_discharge) < 0.05 * q0
