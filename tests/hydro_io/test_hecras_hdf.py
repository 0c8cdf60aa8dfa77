"""HEC-RAS 6 HDF reader (rashdf): a small plan file the test writes with h5py at the documented HEC-RAS
layout (square cells, as HEC-RAS meshes mostly are), fields with analytic values; and a real geometry
file (a subset of the Muncie example that rashdf's repository ships)."""
import warnings
from pathlib import Path

import numpy as np
import pytest

h5py = pytest.importorskip("h5py")  # both are in the test extra; the reader itself names the extra when missing
pytest.importorskip("rashdf")

from breachflow import InputError  # noqa: E402
from breachflow.errors import ParseError  # noqa: E402
from breachflow.io import open_snapshot  # noqa: E402
from breachflow.io import READERS, guess_format  # noqa: E402
from breachflow.field.snapshot import mesh_face_nodes, node_coordinates  # noqa: E402

AREAS = "Geometry/2D Flow Areas"
SERIES = "Results/Unsteady/Output/Output Blocks/Base Output/Unsteady Time Series"
BED = lambda x, y: 100.0 + 0.01 * x - 0.02 * y  # noqa: E731
WSE = lambda x, y: 104.0 - 0.002 * x  # noqa: E731
U = lambda x, y: 1.5 + 0.004 * x - 0.001 * y  # noqa: E731  (linear: exact for square cells)
V = lambda x, y: -0.3 + 0.002 * x + 0.003 * y  # noqa: E731


def square_mesh(nx, ny, d):
    """Cells, faces (cell 0 -> cell 1 normals), ghost cells beyond the perimeter, like HEC-RAS writes."""
    n = nx * ny
    cid = lambda i, j: j * nx + i  # noqa: E731
    centres = np.array([((i + 0.5) * d, (j + 0.5) * d) for j in range(ny) for i in range(nx)])
    faces, normals, mids, fpts = [], [], [], []
    ghost = n
    pt = lambda i, j: j * (nx + 1) + i  # noqa: E731
    for j in range(ny):
        for i in range(nx + 1):  # vertical faces, normal +x
            left = cid(i - 1, j) if i > 0 else None
            right = cid(i, j) if i < nx else None
            if left is None:
                faces.append((right, ghost)); normals.append((-1.0, 0.0)); ghost += 1  # noqa: E702
            elif right is None:
                faces.append((left, ghost)); normals.append((1.0, 0.0)); ghost += 1  # noqa: E702
            else:
                faces.append((left, right)); normals.append((1.0, 0.0))  # noqa: E702
            mids.append((i * d, (j + 0.5) * d))
            fpts.append((pt(i, j), pt(i, j + 1)))
    for j in range(ny + 1):
        for i in range(nx):  # horizontal faces, normal +y
            low = cid(i, j - 1) if j > 0 else None
            up = cid(i, j) if j < ny else None
            if low is None:
                faces.append((up, ghost)); normals.append((0.0, -1.0)); ghost += 1  # noqa: E702
            elif up is None:
                faces.append((low, ghost)); normals.append((0.0, 1.0)); ghost += 1  # noqa: E702
            else:
                faces.append((low, up)); normals.append((0.0, 1.0))  # noqa: E702
            mids.append(((i + 0.5) * d, j * d))
            fpts.append((pt(i, j), pt(i + 1, j)))
    faces = np.array(faces)
    per_cell = [[] for _ in range(n)]
    for f, (a, b) in enumerate(faces):
        per_cell[a].append((f, 1))
        if b < n:
            per_cell[b].append((f, -1))
    info, vals = [], []
    for c in range(n):
        info.append((len(vals), len(per_cell[c])))
        vals += per_cell[c]
    corners = np.array([(i * d, j * d) for j in range(ny + 1) for i in range(nx + 1)])
    return dict(n=n, n_ghost=ghost - n, centres=centres, faces=faces, normals=np.array(normals), mids=np.array(mids),
                info=np.array(info, dtype=np.int32), vals=np.array(vals, dtype=np.int32), corners=corners,
                fpts=np.array(fpts, dtype=np.int32), d=d)


def write_ras_hdf(path, mesh, *, name="Breach Area", times=3, units="SI Units", results=True, cell_velocity=False,
                  scale=(0.5, 1.0, 1.5), wkt=None, chunks=True):
    """HEC-RAS writes its time series chunked (``chunks=True``); contiguous ones occur in other writers' files."""
    n, d = mesh["n"], mesh["d"]
    with h5py.File(path, "w") as f:
        f.attrs["File Type"] = np.bytes_(b"HEC-RAS Results")
        f.attrs["Units System"] = np.bytes_(units.encode())
        if wkt:
            f.attrs["Projection"] = np.bytes_(wkt.encode())
        attrs = np.array([(name.encode(), 0.03, n)], dtype=[("Name", "S16"), ("Mann", "<f4"), ("Cell Count", "<i4")])
        f.create_dataset(f"{AREAS}/Attributes", data=attrs)
        g = f"{AREAS}/{name}"
        ghost_xy = np.full((mesh["n_ghost"], 2), -1.0)
        f[f"{g}/Cells Center Coordinate"] = np.vstack([mesh["centres"], ghost_xy])
        x, y = mesh["centres"].T
        f[f"{g}/Cells Minimum Elevation"] = np.concatenate([BED(x, y), np.full(mesh["n_ghost"], np.nan)]).astype("f4")
        f[f"{g}/Faces Cell Indexes"] = mesh["faces"].astype(np.int32)
        f[f"{g}/Faces NormalUnitVector and Length"] = np.column_stack([mesh["normals"], np.full(len(mesh["faces"]), d)]).astype("f4")
        f[f"{g}/Cells Face and Orientation Info"] = np.vstack([mesh["info"], np.zeros((mesh["n_ghost"], 2), np.int32)])
        f[f"{g}/Cells Face and Orientation Values"] = mesh["vals"]
        f[f"{g}/FacePoints Coordinate"] = mesh["corners"]
        f[f"{g}/Faces FacePoint Indexes"] = mesh["fpts"]
        if not results:
            return path
        stamps = [f"01JAN2024 0{k}:00:00:000".encode() for k in range(times)]
        f[f"{SERIES}/Time Date Stamp (ms)"] = np.array(stamps, dtype="S22")
        s = np.array(scale[:times])[:, None]
        ws = np.concatenate([np.broadcast_to(WSE(x, y), (times, n)), np.zeros((times, mesh["n_ghost"]))], axis=1)
        f.create_dataset(f"{SERIES}/2D Flow Areas/{name}/Water Surface", data=ws.astype("f4"), chunks=chunks or None)
        mx, my = mesh["mids"].T
        fv = s * (mesh["normals"][:, 0] * U(mx, my) + mesh["normals"][:, 1] * V(mx, my))[None, :]
        f.create_dataset(f"{SERIES}/2D Flow Areas/{name}/Face Velocity", data=fv.astype("f4"), chunks=chunks or None)
        if cell_velocity:
            ghost0 = np.zeros((times, mesh["n_ghost"]))
            f[f"{SERIES}/2D Flow Areas/{name}/Cell Velocity - Velocity X"] = np.concatenate([s * 2.0 * np.ones((1, n)), ghost0], axis=1)
            f[f"{SERIES}/2D Flow Areas/{name}/Cell Velocity - Velocity Y"] = np.concatenate([s * -1.0 * np.ones((1, n)), ghost0], axis=1)
    return path


@pytest.fixture()
def mesh():
    return square_mesh(12, 8, 25.0)


def test_plan_hdf_cells_water_surface_and_face_velocities_reconstructed(tmp_path, mesh):
    p = write_ras_hdf(tmp_path / "breach.p01.hdf", mesh)
    assert guess_format([p]) == "hecras_hdf" and "hecras_hdf" in READERS.available()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ds = open_snapshot(p)
    x, y = node_coordinates(ds)
    np.testing.assert_allclose(np.column_stack([x, y]), mesh["centres"])
    assert ds.sizes["node"] == mesh["n"] and ds.sizes["time"] == 3
    np.testing.assert_array_equal(ds.time.values, np.array(["2024-01-01T00", "2024-01-01T01", "2024-01-01T02"], dtype="datetime64[ns]"))
    np.testing.assert_allclose(ds.bed_elevation.values, BED(x, y), rtol=1e-6)           # float32 in the file
    np.testing.assert_allclose(ds.depth.values[1], WSE(x, y) - BED(x, y), atol=2e-5)
    for k, s in enumerate((0.5, 1.0, 1.5)):  # least squares over the 4 faces is exact for linear fields on squares
        np.testing.assert_allclose(ds.u.values[k], s * U(x, y), atol=2e-6)
        np.testing.assert_allclose(ds.v.values[k], s * V(x, y), atol=2e-6)
    # triangles join face-sharing cells only: every edge is between horizontal / vertical neighbours or a diagonal
    f = mesh_face_nodes(ds)
    assert f.shape[0] == 2 * 11 * 7
    edge = np.hypot(x[f] - x[np.roll(f, 1, axis=1)], y[f] - y[np.roll(f, 1, axis=1)])
    assert edge.max() <= 25.0 * np.sqrt(2) + 1e-9
    assert ds.attrs["source_length_unit"] == "m" and "Breach Area (96 cells)" in ds.attrs["source_mesh_areas"]


def test_us_customary_units_cell_velocity_datasets_and_crs(tmp_path, mesh):
    wkt = ('PROJCS["NAD_1983_StatePlane_Indiana_East_FIPS_1301_Feet",GEOGCS["GCS_North_American_1983",DATUM["D_North_American_1983",'
           'SPHEROID["GRS_1980",6378137.0,298.257222101]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]],'
           'PROJECTION["Transverse_Mercator"],PARAMETER["False_Easting",328083.333],PARAMETER["False_Northing",820208.333],'
           'PARAMETER["Central_Meridian",-85.6666666666667],PARAMETER["Scale_Factor",0.999966667],'
           'PARAMETER["Latitude_Of_Origin",37.5],UNIT["US survey foot",0.304800609601219]]')
    p = write_ras_hdf(tmp_path / "ft.p02.hdf", mesh, units="US Customary", cell_velocity=True, times=2, wkt=wkt,
                      chunks=False)
    ds = open_snapshot(p)
    usft = 1200.0 / 3937.0  # US Customary on a state plane in US survey feet: the projection's foot
    x, y = node_coordinates(ds)
    np.testing.assert_allclose(x, mesh["centres"][:, 0] * usft, rtol=1e-12)
    np.testing.assert_allclose(ds.u.values[1], 2.0 * usft, rtol=1e-12)  # the Cell Velocity datasets win
    np.testing.assert_allclose(ds.v.values[0], -0.5 * usft, rtol=1e-12)
    assert ds.attrs["source_length_unit"] == "survey_foot" and "crs" in ds.variables
    assert ds.attrs["source_length_unit_from"] == "Units System: US Customary"
    # without a projection, US Customary is the international foot
    q = write_ras_hdf(tmp_path / "ft.p03.hdf", mesh, units="US Customary", times=2)
    np.testing.assert_allclose(node_coordinates(open_snapshot(q))[0], mesh["centres"][:, 0] * 0.3048, rtol=1e-12)


def test_geometry_hdf_alone_is_a_terrain_and_missing_data_are_named(tmp_path, mesh):
    g = write_ras_hdf(tmp_path / "breach.g01.hdf", mesh, results=False)
    ds = open_snapshot(g)
    x, y = node_coordinates(ds)
    assert (ds.depth.values == 0).all() and "time" not in ds.dims
    np.testing.assert_allclose(ds.bed_elevation.values, BED(x, y), rtol=1e-6)
    p = write_ras_hdf(tmp_path / "other.p01.hdf", mesh, name="Other")
    with pytest.raises(InputError, match="mesh_name='Nope': the 2-D flow areas are Other"):
        open_snapshot(p, mesh_name="Nope")
    with h5py.File(p, "a") as f:
        del f[f"{AREAS}/Other/Cells Minimum Elevation"]
    with pytest.raises(ParseError, match="Cells Minimum Elevation' is missing .*geometry HDF"):
        open_snapshot(p)
    # the geometry from a separate g01 file
    both = open_snapshot([p, write_ras_hdf(tmp_path / "other.g01.hdf", mesh, name="Other", results=False)])
    assert both.sizes["time"] == 3
    junk = tmp_path / "junk.hdf"
    junk.write_text("not hdf")
    with pytest.raises(ParseError, match="not an HDF5 file"):
        open_snapshot(junk)


MUNCIE = Path(__file__).parent / "data" / "hecras" / "Muncie_Perimeter_NW.g05.hdf"


def test_real_geometry_file_muncie_reads_as_a_terrain():
    """A real HEC-RAS 6.5 geometry (USACE Muncie example, the 'Perimeter_NW' area, subset of rashdf's test file)."""
    ds = open_snapshot(MUNCIE)
    with h5py.File(MUNCIE) as f:
        attrs = f[f"{AREAS}/Attributes"][()]
        n = int(attrs["Cell Count"][0])
        g = f[f"{AREAS}/Perimeter_NW"]
        cc = g["Cells Center Coordinate"][:n]
        zmin = g["Cells Minimum Elevation"][:n].astype(float)
    assert ds.sizes["node"] == n and ds.attrs["source_length_unit"] == "survey_foot"  # Indiana East (ftUS)
    x, y = node_coordinates(ds)
    np.testing.assert_allclose(x, cc[:, 0] * 1200.0 / 3937.0, rtol=1e-12)
    np.testing.assert_allclose(ds.bed_elevation.values, zmin * 1200.0 / 3937.0, rtol=1e-12)
    assert 900 < zmin.min() and zmin.max() < 1000  # ft: the Muncie terrain (White River, Indiana)
    assert mesh_face_nodes(ds).shape[0] > n  # a connected triangulation of the cell centres
    assert "crs" in ds.variables


def test_cli_ingests_a_hecras_hdf(tmp_path, mesh):
    from typer.testing import CliRunner

    from breachflow.cli import app

    p = write_ras_hdf(tmp_path / "breach.p01.hdf", mesh)
    r = CliRunner().invoke(app, ["ingest", str(p), "--mesh-name", "Breach Area", "-o", str(tmp_path / "s.nc")])
    assert r.exit_code == 0, r.output
    assert "96 nodes" in r.output and "hecras_hdf" in r.output


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_face_velocity_reconstruction_is_exact_for_uniform_flow_on_any_polygon(seed):
    from breachflow.io.hecras_hdf import cell_velocity_lsq

    rng = np.random.default_rng(seed)
    counts = rng.integers(3, 9, size=50)                       # polygon cells with 3..8 faces
    n_face = int(counts.sum())
    ang = rng.uniform(0, 2 * np.pi, n_face)
    normals = np.column_stack([np.cos(ang), np.sin(ang)])
    lengths = rng.uniform(0.5, 20.0, n_face)
    order = rng.permutation(n_face)                            # faces listed in any order
    info = np.column_stack([np.cumsum(counts) - counts, counts])
    values = np.column_stack([order, np.ones(n_face, int)])
    uv = rng.normal(size=(4, 50, 2))                           # 4 steps, one uniform velocity per cell
    cell_of_row = np.repeat(np.arange(50), counts)
    fv = np.zeros((4, n_face))
    fv[:, order] = np.einsum("tcj,cj->tc", uv[:, cell_of_row], normals[order])
    np.testing.assert_allclose(cell_velocity_lsq(normals, lengths, fv, info, values), uv, atol=1e-10)


def test_implausible_hdf_value_names_file_area_cell_and_step(tmp_path, mesh):
    p = write_ras_hdf(tmp_path / "big.p01.hdf", mesh)
    with h5py.File(p, "a") as f:
        ws = f[f"{SERIES}/2D Flow Areas/Breach Area/Water Surface"]
        a = ws[()]
        a[2, 17] = 1e6
        ws[...] = a
    with pytest.raises(InputError, match=r"big\.p01\.hdf: depth: implausible water depth .*Water Surface of 2-D flow area "
                                         r"'Breach Area', cell index 17, time step 2"):
        open_snapshot(p)


MUNCIE_SI = Path(__file__).parent / "data" / "hecras" / "Muncie2DOnly_SI.p01.steps_0_25_48.hdf"


def test_real_plan_file_muncie_matches_mdal_s_expectations():
    """A real HEC-RAS 6.1 plan with results (MDAL's test file, steps 0, 25, 48); expected values from MDAL's tests."""
    ds = open_snapshot(MUNCIE_SI)
    assert ds.sizes["node"] == 2972 and ds.sizes["time"] == 3 and ds.attrs["source_length_unit"] == "m"
    assert ds.bed_elevation.values[0] == pytest.approx(289.453125, abs=1e-3)
    assert ds.water_surface.values[1, 435] == pytest.approx(283.2630, abs=1e-3)
    hours = (ds.time.values - np.datetime64("1900-01-02T00:00:00")) / np.timedelta64(1, "h")
    np.testing.assert_allclose(hours, [0.0, 2.0833333333333335, 4.0])
    # velocities reconstructed from the face velocities: plausible for this river flood, zero where dry
    speed = np.hypot(ds.u.values, ds.v.values)
    assert 0.5 < speed[1].max() < 5.0 and (speed[ds.wet.values == 0] == 0).all()
    # the reconstruction reproduces the file's face velocities between two wet cells to within their spread
    with h5py.File(MUNCIE_SI) as f:
        g = f[f"{AREAS}/Muncie2D"]
        cells = g["Faces Cell Indexes"][()]
        nrm = g["Faces NormalUnitVector and Length"][()][:, :2]
        fv = f[f"{SERIES}/2D Flow Areas/Muncie2D/Face Velocity"][1]
    inner = (cells < 2972).all(axis=1)
    a, b = cells[inner, 0], cells[inner, 1]
    both = (ds.wet.values[1, a] == 1) & (ds.wet.values[1, b] == 1) & (np.abs(fv[inner]) > 0.05)
    mean_u = 0.5 * (ds.u.values[1, a] + ds.u.values[1, b])
    mean_v = 0.5 * (ds.v.values[1, a] + ds.v.values[1, b])
    recon = mean_u * nrm[inner, 0] + mean_v * nrm[inner, 1]
    err = np.abs(recon - fv[inner])[both]
    assert both.sum() > 500 and np.median(err) < 0.25 * np.median(np.abs(fv[inner][both]))


@pytest.mark.parametrize("damage", ["no cell count", "short faces", "bad time stamps"])
def test_other_hdf_layouts_are_named_as_not_supported(tmp_path, mesh, damage):
    p = write_ras_hdf(tmp_path / "odd.p01.hdf", mesh)
    with h5py.File(p, "a") as f:
        if damage == "no cell count":
            del f[f"{AREAS}/Attributes"]
            f[f"{AREAS}/Attributes"] = np.array([(b"Breach Area", 0.03)], dtype=[("Name", "S16"), ("Mann", "<f4")])
        elif damage == "short faces":
            g = f[f"{AREAS}/Breach Area"]
            fp = g["Faces FacePoint Indexes"][()]
            del g["Faces FacePoint Indexes"]
            g["Faces FacePoint Indexes"] = fp[:, :1]
        else:
            del f[f"{SERIES}/Time Date Stamp (ms)"]
            f[f"{SERIES}/Time Date Stamp (ms)"] = np.array([b"yesterday"] * 3)
    with pytest.raises(ParseError, match="HEC-RAS HDF layout not supported") as ei:
        open_snapshot(p)
    assert ei.value.path.endswith("odd.p01.hdf")
