"""``write_hecras_hdf``: a snapshot as a HEC-RAS 6 2-D plan HDF, read back through the ``hecras_hdf`` reader
(rashdf). Expected values are analytic (fields linear in x and y: a triangle's centroid value is the mean of
its nodes', an edge's midpoint value the mean of its ends'), stored in float32 as HEC-RAS stores them."""
import numpy as np
import pytest
from typer.testing import CliRunner

h5py = pytest.importorskip("h5py")
pytest.importorskip("rashdf")

from breachflow.errors import InputError  # noqa: E402
from breachflow.field import grid_snapshot, write_snapshot
from breachflow.io import open_snapshot  # noqa: E402
from breachflow.io import to_unaligned_mesh, write_hecras_hdf  # noqa: E402
from breachflow.field.snapshot import mesh_face_nodes, node_coordinates  # noqa: E402

FT = 0.3048
BED = lambda x, y: 30.0 + 0.002 * x - 0.004 * y  # noqa: E731
WSE = lambda x, y: 36.0 - 0.001 * x + 0.0005 * y  # noqa: E731
U = lambda x, y: 1.2 + 0.0005 * x + 0.001 * y  # noqa: E731
V = lambda x, y: -0.4 + 0.0002 * x - 0.0007 * y  # noqa: E731
AREA = "Geometry/2D Flow Areas/breachflow"
SERIES = "Results/Unsteady/Output/Output Blocks/Base Output/Unsteady Time Series/2D Flow Areas/breachflow"


def _grid(nx=31, ny=21, dx=10.0, obstacle=None, crs=None, times=None, uniform=False):
    x, y = -150.0 + dx * np.arange(nx), -100.0 + dx * np.arange(ny)
    X, Y = np.meshgrid(x, y)
    u, v = (np.full(X.shape, 1.3), np.full(X.shape, -0.6)) if uniform else (U(X, Y), V(X, Y))
    h = WSE(X, Y) - BED(X, Y)
    if times is not None:
        s = np.linspace(0.5, 1.0, len(times))[:, None, None]
        h, u, v = h[None] * s, u[None] * s, v[None] * s
    return grid_snapshot(x, y, BED(X, Y), h, u, v, obstacle=obstacle, crs_wkt=crs, time=times)


@pytest.mark.parametrize("units", ["m", "ft"])
@pytest.mark.parametrize("seed", [0, 5])
def test_cells_are_the_triangles_with_analytic_values(tmp_path, units, seed):
    m = to_unaligned_mesh(_grid(), 500, seed)
    p = write_hecras_hdf(m, tmp_path / "b.p01.hdf", units=units, cell_velocity=True)
    k = 1.0 if units == "m" else 1 / FT
    x, y = node_coordinates(m)
    tri = mesh_face_nodes(m)
    cx, cy = x[tri].mean(axis=1), y[tri].mean(axis=1)
    with h5py.File(p) as f:
        assert f.attrs["Units System"] == (b"SI Units" if units == "m" else b"US Customary")
        n = int(f["Geometry/2D Flow Areas/Attributes"][()]["Cell Count"][0])
        assert n == tri.shape[0]
        np.testing.assert_allclose(f[f"{AREA}/Cells Center Coordinate"][:n], np.column_stack([cx, cy]) * k, rtol=1e-12)
        fp = f[f"{AREA}/Faces FacePoint Indexes"][()]
        fc = f[f"{AREA}/Faces Cell Indexes"][()]
        nl = f[f"{AREA}/Faces NormalUnitVector and Length"][()]
        fv = f[f"{SERIES}/Face Velocity"][()]
        ws = f[f"{SERIES}/Water Surface"][()]
    # faces: every triangle edge once; interior ones between two cells, perimeter ones to a ghost cell
    assert fp.shape[0] == np.unique(np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1), axis=0).shape[0]
    ghost = fc[:, 1] >= n
    assert ghost.sum() == np.unique(fc[ghost, 1]).size and (fc[:, 0] < n).all()
    # normal points from the first cell to the second (its centre is on the normal's side), length = edge length
    d = np.column_stack([x[fp[:, 1]] - x[fp[:, 0]], y[fp[:, 1]] - y[fp[:, 0]]])
    np.testing.assert_allclose(nl[:, 2], np.hypot(*d.T) * k, rtol=1e-6)
    mid = 0.5 * np.column_stack([x[fp[:, 0]] + x[fp[:, 1]], y[fp[:, 0]] + y[fp[:, 1]]])
    to_first = np.column_stack([cx[fc[:, 0]], cy[fc[:, 0]]]) - mid
    assert (np.einsum("ij,ij->i", to_first, nl[:, :2]) < 0).all()
    # face velocity = normal component of the (linear) velocity at the edge midpoint
    ref = nl[:, 0] * U(mid[:, 0], mid[:, 1]) + nl[:, 1] * V(mid[:, 0], mid[:, 1])
    np.testing.assert_allclose(fv[0], ref * k, atol=1e-5 * k)
    np.testing.assert_allclose(ws[0, :n], WSE(cx, cy) * k, rtol=1e-6)
    r = open_snapshot(p)
    rx, ry = node_coordinates(r)
    np.testing.assert_allclose(rx, cx, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(r.bed_elevation.values, BED(cx, cy), atol=2e-5)
    np.testing.assert_allclose(r.depth.values[0], WSE(cx, cy) - BED(cx, cy), atol=4e-5)
    np.testing.assert_allclose(r.u.values[0], U(cx, cy), atol=1e-6)  # the written cell velocities
    np.testing.assert_allclose(r.v.values[0], V(cx, cy), atol=1e-6)
    assert r.attrs["source_length_unit"] == units


def test_face_velocities_alone_give_a_uniform_flow_exactly(tmp_path):
    """HEC-RAS writes face velocities unless cell velocities are asked for: the reader's least-squares
    reconstruction is exact for a uniform flow (and close for a linear one)."""
    m = to_unaligned_mesh(_grid(uniform=True), 400, 3)
    r = open_snapshot(write_hecras_hdf(m, tmp_path / "u.p01.hdf"))
    np.testing.assert_allclose(r.u.values, 1.3, atol=1e-6)
    np.testing.assert_allclose(r.v.values, -0.6, atol=1e-6)
    m = to_unaligned_mesh(_grid(), 400, 3)
    r = open_snapshot(write_hecras_hdf(m, tmp_path / "l.p01.hdf"))
    x, y = node_coordinates(r)
    # the fit of three mid-edge normal components of a linear field is off by at most |grad u| h
    h = 20.0
    assert np.abs(r.u.values[0] - U(x, y)).max() < 0.0011 * h
    assert np.abs(r.v.values[0] - V(x, y)).max() < 0.0011 * h


def test_holes_dates_crs_and_bad_input(tmp_path):
    ob = np.zeros((21, 31), bool)
    ob[9:11, 5:25] = True  # a no-flow levee: a hole in the mesh, its edges perimeter faces
    t = np.array(["2021-05-01T00:00", "2021-05-01T00:30"], dtype="datetime64[ns]")
    g = _grid(obstacle=ob, crs="EPSG:32615", times=t)
    m = to_unaligned_mesh(g, 600, 1)
    p = write_hecras_hdf(m, tmp_path / "h.p01.hdf", units="ft")
    r = open_snapshot(p)
    np.testing.assert_array_equal(r.time.values, t)
    assert "crs" in r.variables and r.attrs["source_length_unit"] in ("ft", "survey_foot")
    x, y = node_coordinates(r)
    np.testing.assert_allclose(x.min(), m.mesh2d_node_x.values.min(), atol=10.0)
    # the hole stays a hole: its outline is perimeter faces (to ghost cells), no face crosses it
    with h5py.File(p) as f:
        n = int(f["Geometry/2D Flow Areas/Attributes"][()]["Cell Count"][0])
        fc = f[f"{AREA}/Faces Cell Indexes"][()]
        fp = f[f"{AREA}/Faces FacePoint Indexes"][()]
        xy = f[f"{AREA}/FacePoints Coordinate"][()] * FT
    mx, my = 0.5 * (xy[fp[:, 0]] + xy[fp[:, 1]]).T
    hole_edge = (np.abs(my) < 16.0) & (mx > -90.0) & (mx < 80.0)
    assert (fc[hole_edge, 1] >= n).sum() > 20
    cc = np.column_stack([m.mesh2d_node_x.values[mesh_face_nodes(m)].mean(axis=1),
                          m.mesh2d_node_y.values[mesh_face_nodes(m)].mean(axis=1)])
    inner = fc[:, 1] < n
    crosses = (np.sign(cc[fc[inner, 0], 1]) != np.sign(cc[fc[inner, 1], 1])) & (np.abs(cc[fc[inner, 0], 0]) < 80.0)
    assert not crosses.any()
    with pytest.raises(InputError, match="units"):
        write_hecras_hdf(m, tmp_path / "x.hdf", units="cm")
    with pytest.raises(InputError, match="16 characters"):
        write_hecras_hdf(m, tmp_path / "x.hdf", area_name="a much too long area name")
    assert not (tmp_path / "x.hdf").exists()


def test_cli_export_hecras_hdf_and_ingest_back(tmp_path):
    from breachflow.cli import app

    snap = write_snapshot(_grid(nx=21, ny=16), tmp_path / "s.nc")
    run = CliRunner()
    r = run.invoke(app, ["export", str(snap), "-f", "hecras_hdf", "-o", str(tmp_path / "plan"), "--nodes", "200"])
    assert r.exit_code == 0, r.output
    assert (tmp_path / "plan.p01.hdf").exists()
    r = run.invoke(app, ["ingest", str(tmp_path / "plan.p01.hdf"), "-o", str(tmp_path / "back.nc")])
    assert r.exit_code == 0, r.output
    r = run.invoke(app, ["export", str(snap), "-f", "esri", "--nodes", "200", "-o", str(tmp_path / "e")])
    assert r.exit_code != 0 and isinstance(r.exception, InputError)
