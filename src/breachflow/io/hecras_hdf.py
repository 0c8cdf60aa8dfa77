"""HEC-RAS 6 HDF5 plan / geometry files → mesh snapshot over the 2-D flow-area cell centres (reader
``hecras_hdf``; needs the optional packages ``rashdf`` and ``h5py``: ``pip install breachflow[hecras]``).

Read through ``rashdf.RasPlanHdf`` (an ``h5py.File``) at the documented HEC-RAS layout:

* ``Geometry/2D Flow Areas/Attributes`` (``Name``, ..., ``Cell Count``: the real cells; rows beyond are
  the perimeter's ghost cells) and per area ``Cells Center Coordinate``, ``Cells Minimum Elevation``,
  ``Faces Cell Indexes``, ``Faces FacePoint Indexes``, ``Faces NormalUnitVector and Length``, ``Cells Face and Orientation Info`` /
  ``Values``;
* ``Results/Unsteady/Output/Output Blocks/Base Output/Unsteady Time Series``: ``Time Date Stamp (ms)``
  and per area ``Water Surface`` (time × cell), ``Face Velocity`` (time × face, along the face's normal
  unit vector) and, when written, ``Cell Velocity - Velocity X`` / ``Y`` (rashdf
  ``mesh_timeseries_output``);
* root attributes ``Units System`` (``US Customary`` → ft, or US survey feet when ``Projection`` is in
  them; ``SI Units`` → m) and ``Projection`` (WKT).

The snapshot's nodes are the real cell centres; its triangles are the Delaunay triangles of the centres
whose three cells meet at one face point (so nothing spans a concave boundary or a hole). Values:
bed = ``Cells Minimum Elevation``; depth = water surface − bed (≤ 0 dry); velocity = the cell velocity
datasets when present, else reconstructed from the face-normal velocities of the cell's faces by the
face-length-weighted least-squares fit ``u = argmin Σ_f L_f (n_f · u − V_f)²`` (exact for a uniform flow).
A geometry file without results (``.g01.hdf``) reads as a terrain (depth 0, velocity 0).
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError, ParseError

AREAS = "Geometry/2D Flow Areas"
SERIES = "Results/Unsteady/Output/Output Blocks/Base Output/Unsteady Time Series"


def _import_rashdf():
    try:
        import rashdf  # noqa: F401
    except ImportError:
        raise InputError("reading HEC-RAS HDF files needs the optional packages rashdf and h5py: "
                         "pip install 'breachflow[hecras]'") from None
    return rashdf


def _text(v) -> str:
    return v.decode("utf-8", "replace") if isinstance(v, (bytes, np.bytes_)) else str(v)


def _need(f, path: str, file) -> np.ndarray:
    if path not in f:
        raise ParseError(f"HEC-RAS HDF: dataset {path!r} is missing (a geometry-stripped plan file? pass the "
                         "geometry HDF, g##.hdf, of the plan as well)", path=file)
    return f[path][()]


def cell_velocity_lsq(normals: np.ndarray, lengths: np.ndarray, face_v: np.ndarray, info: np.ndarray,
                      values: np.ndarray) -> np.ndarray:
    """Cell velocities ``(nt, n_cell, 2)`` from face-normal velocities ``face_v`` ``(nt, n_face)``.

    Per cell the faces listed in ``Cells Face and Orientation`` (*info* rows ``start, count``; *values*
    column 0 the face index) give ``u = (Σ L n nᵀ)⁻¹ Σ L V n`` (pseudo-inverse when the normals are not
    independent). Vectorised: the sums are one sparse product per component, the 2 × 2 solves batched.
    """
    from scipy.sparse import csr_matrix

    n_cell = info.shape[0]
    counts = info[:, 1].astype(np.int64)
    cell = np.repeat(np.arange(n_cell), counts)
    first = np.cumsum(counts) - counts                      # position of each cell's first pair in `cell`
    rows = np.arange(cell.size) - np.repeat(first, counts) + np.repeat(info[:, 0].astype(np.int64), counts)
    face = values[rows, 0].astype(np.int64)
    nrm, w = normals[face], lengths[face]
    a = np.zeros((n_cell, 2, 2))
    np.add.at(a, cell, w[:, None, None] * nrm[:, :, None] * nrm[:, None, :])
    pick = csr_matrix((np.ones(face.size), (cell, np.arange(face.size))), shape=(n_cell, face.size))
    lv = face_v[:, face] * w[None, :]                      # (nt, m)
    rhs = np.stack([(pick @ (lv * nrm[None, :, k]).T).T for k in (0, 1)], axis=-1)  # (nt, n_cell, 2)
    return np.einsum("cij,tcj->tci", np.linalg.pinv(a), rhs)


def _triangles(cx, cy, faces_cells, faces_points, n_cell) -> np.ndarray:
    """Delaunay triangles of the cell centres whose three cells meet at one face point (mesh vertex), so
    no triangle spans a concave boundary or a hole."""
    from itertools import combinations

    from scipy.spatial import Delaunay

    if n_cell < 3:
        raise InputError(f"a 2-D flow area needs at least 3 cells for a mesh, has {n_cell}")
    around: dict[int, set] = {}
    for (a, b), (p, q) in zip(faces_cells.tolist(), faces_points.tolist()):
        for fp in (p, q):
            cells = around.setdefault(fp, set())
            cells.update(c for c in (a, b) if 0 <= c < n_cell)
    allowed = set()
    for cells in around.values():
        allowed.update(combinations(sorted(cells), 3))
    tri = Delaunay(np.column_stack([cx, cy])).simplices.astype(np.int64)
    srt = np.sort(tri, axis=1)
    ok = np.fromiter((tuple(t) in allowed for t in srt.tolist()), dtype=bool, count=len(srt))
    tri = tri[ok]
    a, b, c = tri.T
    area2 = (cx[b] - cx[a]) * (cy[c] - cy[a]) - (cx[c] - cx[a]) * (cy[b] - cy[a])
    tri[area2 < 0] = tri[area2 < 0][:, ::-1]
    return tri


def open_hecras_hdf(paths, *, units=None, crs=None, plausibility="raise", mesh_name=None, **unused):
    """HEC-RAS plan (and optionally geometry) HDF → mesh snapshot (SI); see the module doc."""
    from ..units import ureg
    from ..field.snapshot import check_plausibility, mesh_snapshot
    from . import unknown_options

    unknown_options("hecras_hdf", unused)
    _import_rashdf()
    from rashdf import RasPlanHdf

    from pathlib import Path

    paths = [Path(p) for p in paths]
    hdfs = [p for p in paths if p.suffix.lower() in (".hdf", ".h5", ".hdf5")]
    if not hdfs or len(hdfs) != len(paths) or len(hdfs) > 2:
        raise InputError("hecras_hdf reader: give a plan HDF (p##.hdf) and optionally its geometry HDF (g##.hdf)")
    files = []
    try:
        for p in hdfs:
            try:
                files.append(RasPlanHdf(str(p)))
            except OSError as exc:
                raise ParseError(f"not an HDF5 file ({exc})", path=p) from None
        with_results = [f for f in files if SERIES in f]
        plan = with_results[0] if with_results else None
        geom = next((f for f in files if f"{AREAS}/Attributes" in f and f is not plan), None)
        if plan is not None and f"{AREAS}/Attributes" in plan and geom is None:
            geom = plan
        if geom is None:
            raise ParseError(f"HEC-RAS HDF: no {AREAS}/Attributes (no 2-D flow area)", path=hdfs[0])
        root = {k: _text(v) for k, v in geom.attrs.items()}
        if plan is not None:
            root.update({k: _text(v) for k, v in plan.attrs.items() if k in ("Units System", "Projection")})
        system = root.get("Units System", "").strip().lower()
        file_unit = {"us customary": "ft", "si units": "m", "si": "m", "metric": "m"}.get(system)
        if file_unit == "ft" and root.get("Projection"):  # US Customary on a US-survey-foot state plane
            from .asc import prj_length_unit

            file_unit = {"survey_foot": "survey_foot"}.get(prj_length_unit(root["Projection"]), "ft")
        unit = str(units) if units is not None else file_unit
        if unit is None:
            raise InputError(f"{hdfs[0]}: no 'Units System' attribute; pass units='m' or 'ft'")
        to_m = float(ureg.Quantity(1.0, unit).to("m").magnitude)
        attrs = geom[f"{AREAS}/Attributes"][()]
        names = [_text(n) for n in attrs["Name"]]
        counts = [int(c) for c in attrs["Cell Count"]]
        if mesh_name is not None:
            if mesh_name not in names:
                raise InputError(f"mesh_name={mesh_name!r}: the 2-D flow areas are {', '.join(names)}")
            chosen = [names.index(mesh_name)]
        else:
            chosen = list(range(len(names)))
        times = None
        if plan is not None:
            times = np.array(plan.unsteady_datetimes(), dtype="datetime64[ns]")
        xs, ys, beds, deps, us, vs, tris = [], [], [], [], [], [], []
        offset = 0
        for a in chosen:
            name, n = names[a], counts[a]
            base = f"{AREAS}/{name}"
            cc = _need(geom, f"{base}/Cells Center Coordinate", geom.filename)[:n]
            bed = _need(geom, f"{base}/Cells Minimum Elevation", geom.filename)[:n].astype(float)
            if not np.isfinite(bed).all():
                k = int(np.argmax(~np.isfinite(bed)))
                raise ParseError(f"2-D flow area {name!r}: cell {k} has no minimum elevation (NaN: no terrain under it)",
                                 path=geom.filename)
            fcells = _need(geom, f"{base}/Faces Cell Indexes", geom.filename).astype(np.int64)
            fpts = _need(geom, f"{base}/Faces FacePoint Indexes", geom.filename).astype(np.int64)
            tri = _triangles(cc[:, 0], cc[:, 1], fcells, fpts, n)
            if plan is not None:
                ws = _series(plan, name, "Water Surface", n)
                depth = ws - bed[None, :]
                u, v = _velocities(plan, geom, name, base, n, ws.shape[0])
            else:
                depth = np.zeros((1, n))
                u = v = np.zeros((1, n))
            xs.append(cc[:, 0])
            ys.append(cc[:, 1])
            beds.append(bed)
            deps.append(depth)
            us.append(u)
            vs.append(v)
            tris.append(tri + offset)
            offset += n
        crs_wkt = crs or root.get("Projection") or None
        source_files = [str(p) for p in hdfs]
    except (KeyError, IndexError, ValueError, TypeError, OSError) as exc:  # a layout other than HEC-RAS 6's
        if isinstance(exc, (InputError, ParseError)):
            raise
        raise ParseError(f"HEC-RAS HDF layout not supported ({type(exc).__name__}: {exc})",
                         path=files[-1].filename if files else hdfs[0]) from None
    finally:
        for f in files:
            f.close()
    depth = np.concatenate(deps, axis=1) * to_m
    u = np.concatenate(us, axis=1) * to_m
    v = np.concatenate(vs, axis=1) * to_m
    terrain = times is None
    ds = mesh_snapshot(np.concatenate(xs) * to_m, np.concatenate(ys) * to_m, np.concatenate(tris),
                       np.concatenate(beds) * to_m, depth[0] if terrain else depth, u[0] if terrain else u,
                       v[0] if terrain else v, time=None if terrain else times, crs_wkt=crs_wkt,
                       source="HEC-RAS HDF read by breachflow (reader 'hecras_hdf', rashdf)", source_files=source_files,
                       node_ids=np.concatenate([np.arange(counts[a]) for a in chosen]))
    ds["mesh2d_node_id"].attrs["long_name"] = "HEC-RAS cell index within its 2-D flow area"
    ds.attrs.update(breachflow_reader="hecras_hdf", source_length_unit=unit,
                    source_length_unit_from="user" if units is not None else f"Units System: {root.get('Units System')}",
                    source_mesh_areas="; ".join(f"{names[a]} ({counts[a]} cells)" for a in chosen),
                    interpolation="nodes at the cell centres; bed = Cells Minimum Elevation; depth = water surface - bed; "
                                  "triangles = Delaunay triangles of cells meeting at a face point")
    if terrain:
        ds.attrs["breachflow_content"] = "terrain: a geometry HDF without results (depth 0, velocity 0)"
    starts = np.cumsum([0] + [counts[a] for a in chosen])
    plan_file = source_files[0] if times is not None and len(hdfs) == 1 else None

    def locate(key, idx):  # HDF has no lines: name the file, dataset, area, cell and step
        node = idx.get("node")
        if node is None:
            return None
        k = int(np.searchsorted(starts, node, side="right")) - 1
        area, cell = names[chosen[k]], int(node - starts[k])
        step = idx.get("time")
        what = {"bed_elevation": "Cells Minimum Elevation", "speed": "Face Velocity / Cell Velocity"}.get(key, "Water Surface")
        where = f"{what} of 2-D flow area {area!r}, cell index {cell}" + (f", time step {step}" if step is not None else "")
        return (plan_file or source_files[-1], None, where)

    return check_plausibility(ds, mode=plausibility, raw_depth=None if terrain else depth, locate=locate)


def _series(plan, name: str, var: str, n: int | None) -> np.ndarray:
    """``(time, cell | face)`` values of a time-series output through rashdf's ``mesh_timeseries_output``
    (cells truncated to the real ones); rashdf 0.12 fails on unchunked (contiguous) datasets, which are then
    read directly at the same documented path."""
    try:
        return np.asarray(plan.mesh_timeseries_output(name, var).values, dtype=float)
    except ValueError:
        a = np.asarray(plan[f"{SERIES}/2D Flow Areas/{name}/{var}"][()], dtype=float)
        return a[:, :n] if n is not None else a


def _velocities(plan, geom, name, base, n, nt):
    """Cell velocities: the Cell Velocity datasets when written, else the face-normal reconstruction."""
    cx = f"{SERIES}/2D Flow Areas/{name}/Cell Velocity - Velocity X"
    if cx in plan and f"{SERIES}/2D Flow Areas/{name}/Cell Velocity - Velocity Y" in plan:
        return _series(plan, name, "Cell Velocity - Velocity X", n), _series(plan, name, "Cell Velocity - Velocity Y", n)
    if f"{SERIES}/2D Flow Areas/{name}/Face Velocity" not in plan:
        return np.zeros((nt, n)), np.zeros((nt, n))
    fv = _series(plan, name, "Face Velocity", None)
    nl = _need(geom, f"{base}/Faces NormalUnitVector and Length", geom.filename).astype(float)
    info = _need(geom, f"{base}/Cells Face and Orientation Info", geom.filename)[:n]
    vals = _need(geom, f"{base}/Cells Face and Orientation Values", geom.filename)
    uv = cell_velocity_lsq(nl[:, :2], nl[:, 2], fv, info, vals)
    return uv[..., 0], uv[..., 1]
