"""ADH / SMS reader: a mesh (:mod:`.adh_mesh`), datasets (:mod:`.sms_dat`, :mod:`.sms_binary`) and the
``.bc`` cards that tell the length and time units → UGRID mesh snapshot (SI).

Dataset roles come from the NAME (English and national-language names, see ``_ROLE_PATTERNS``) or the
``roles=`` option; a previous-step dataset ("Old Depth") is never taken silently for the current one.
Plausibility errors name the file and line of the offending value.
"""
from __future__ import annotations

import re
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import BreachflowWarning, InputError, ParseError
from ._text import LineReader, as_text, to_float, to_int
from .adh_mesh import (  # noqa: F401  (re-exported: the public names of this reader)
    ELEMENT_CARDS, KNOWN_MESH_CARDS, LINE_ELEMENT_CARDS, MESH_EXTENSIONS, SKIP_BLOCKS, MeshData, NodeString, read_mesh,
)
from .sms_dat import (  # noqa: F401
    ADH_TIME_CODES, SMS_TIME_CODES, TIME_WORDS, DatDataset, read_dat, time_unit_seconds,
)


# --------------------------------------------------------------------------------------------------
# .bc: units
# --------------------------------------------------------------------------------------------------

@dataclass
class BcInfo:
    path: Path
    gravity: float | None = None
    gravity_line: int | None = None
    length_unit: str | None = None
    output_time_code: int | None = None  # SERIES AWRITE out_units (ADH code) drives the .dat TIMEUNITS


def read_bc(path) -> BcInfo:
    """Read what an ADH ``.bc`` file says about units: ``MP G`` (9.81 → m, 32.2 → ft) and AWRITE units."""
    path = Path(path)
    info = BcInfo(path)
    with LineReader(path) as rd:
        while True:
            raw = rd.readline()
            if raw is None:
                break
            text = as_text(raw, path, rd.line_no).split("!", 1)[0].strip()
            toks = text.split()
            if len(toks) >= 3 and toks[0].upper() == "MP" and toks[1].upper() == "G":
                g = to_float(toks[2], path=path, line=rd.line_no, what="MP G card")
                info.gravity, info.gravity_line = g, rd.line_no
                if abs(g - 9.81) < 0.05:
                    info.length_unit = "m"
                elif abs(g - 32.17) < 0.2:
                    info.length_unit = "ft"
                else:
                    raise ParseError(f"MP G {g:g} is neither ~9.81 (m/s^2) nor ~32.2 (ft/s^2); give units= explicitly",
                                     path=path, line=rd.line_no)
            elif len(toks) >= 5 and toks[0].upper() == "SERIES" and toks[1].upper() == "AWRITE":
                code = to_int(toks[4], path=path, line=rd.line_no, what="SERIES AWRITE output units")
                if code not in ADH_TIME_CODES:
                    raise ParseError(f"SERIES AWRITE output time-unit code {code} not in 0..4", path=path, line=rd.line_no)
                info.output_time_code = code
    return info


# --------------------------------------------------------------------------------------------------
# the reader: mesh + datasets (+ .bc) -> UGRID mesh snapshot
# --------------------------------------------------------------------------------------------------

#: dataset NAME / file-name patterns per role, English and the names national tools write (German
#: Hydro_AS-2D / BASEMENT: Wassertiefe, WSPL; French hauteur, cote; Spanish/Italian calado, tirante...)
_ROLE_PATTERNS = (
    ("water_surface", re.compile(r"water.?surface|\bwse\b|\bwsel?\b|(?<!bed )(?<!bottom )(?<!ground )elevation|stage|"
                                 r"\bhead\b|\beta\b|wasserspiegel|\bwspl?\w*|niveau|\bcote\b|\bnivel\b|waterstand|livello", re.I)),
    ("depth", re.compile(r"depth|\bdep\b|tiefe|hauteur|profondeur|calado|profundidad|tirante|diepte", re.I)),
)
#: names of previous-step / initial-state datasets (ADH "Old Depth", SMS "Initial ...")
_OLD = re.compile(r"\b(old|prev|previous|initial|last|alt|ancien)\b", re.I)
ROLES = ("depth", "water_surface", "velocity", "ignore")


def dataset_role(ds: DatDataset) -> str | None:
    """``velocity`` (any vector), ``depth`` or ``water_surface`` from the NAME (file name as fallback)."""
    if ds.vector:
        return "velocity"
    for text in (ds.name, ds.path.stem):
        for role, pat in _ROLE_PATTERNS:
            if pat.search(text or ""):
                return role
    return None


def assign_roles(datasets: list[DatDataset], roles: dict | None = None) -> tuple[dict, list]:
    """``{role: dataset}`` and the ignored datasets' descriptions.

    *roles* maps a dataset NAME, a file name or a file stem to ``depth``, ``water_surface``,
    ``velocity`` or ``ignore``; other datasets get their role from the name patterns. A dataset whose name
    marks a previous step or initial state ("Old Depth") is used only when nothing else has that role,
    with a warning; when both exist the current one wins and the old one is reported as ignored.
    """
    roles = dict(roles or {})
    for key, role in roles.items():
        if role not in ROLES:
            raise InputError(f"roles[{key!r}] = {role!r}: choose one of {', '.join(ROLES)}")
    given: dict[int, str] = {}
    for key, role in roles.items():
        hits = [i for i, d in enumerate(datasets) if key in (d.name, d.path.name, d.path.stem, str(d.path))]
        if not hits:
            raise InputError(f"roles: no dataset named {key!r}; the datasets are "
                             + ", ".join(f"{d.name!r} ({d.path.name})" for d in datasets))
        for i in hits:
            given[i] = role
    out: dict[str, DatDataset] = {}
    ignored, old = [], []
    for i, d in enumerate(datasets):  # explicit roles first
        role = given.get(i)
        if role in (None, "ignore"):
            continue
        if role in out:
            raise InputError(f"roles: two datasets for {role}: {out[role].name!r} and {d.name!r}")
        if role == "velocity" and not d.vector:
            raise InputError(f"roles: dataset {d.name!r} ({d.path.name}) is scalar; velocity needs a vector dataset")
        if role != "velocity" and d.vector:
            raise InputError(f"roles: dataset {d.name!r} ({d.path.name}) is a vector; {role} needs a scalar dataset")
        out[role] = d
    for i, d in enumerate(datasets):
        if i in given:
            if given[i] == "ignore":
                ignored.append(f"{d.name} ({d.path.name}, roles=ignore)")
            continue
        role = dataset_role(d)
        if role is not None and _OLD.search(d.name or ""):
            old.append((role, d))
            continue
        if role is None or role in out:
            ignored.append(f"{d.name} ({d.path.name})")
            continue
        out[role] = d
    for role, d in old:
        if role in out:
            ignored.append(f"{d.name} ({d.path.name}, a previous-step dataset)")
            warnings.warn(f"{d.path.name}: dataset {d.name!r} looks like a previous step / initial state: ignored, "
                          f"{out[role].name!r} is used as {role}", BreachflowWarning, stacklevel=3)
        else:
            out[role] = d
            warnings.warn(f"{d.path.name}: dataset {d.name!r} looks like a previous step / initial state but is the "
                          f"only {role} dataset: used as {role}; pass roles={{{d.name!r}: '{role}'}} to confirm or "
                          "give the current dataset", BreachflowWarning, stacklevel=3)
    return out, ignored


def _node_values(ds: DatDataset, mesh: MeshData, step: int) -> np.ndarray:
    """Values of one step at the mesh nodes (sorted by id); element values are averaged to nodes."""
    vals = ds.values[step]
    n_node = mesh.node_ids.size
    if ds.on_faces:
        if vals.shape[0] != mesh.faces.shape[0]:
            raise ParseError(f"dataset {ds.name!r} has NC={vals.shape[0]} element values but the mesh has "
                             f"{mesh.faces.shape[0]} elements", path=ds.path, line=ds.ts_lines[step])
        f = mesh.faces
        acc = np.zeros((n_node,) + vals.shape[1:])
        cnt = np.zeros(n_node)
        for k in range(f.shape[1]):
            ok = f[:, k] >= 0
            np.add.at(acc, f[ok, k], vals[ok])
            np.add.at(cnt, f[ok, k], 1.0)
        cnt = np.maximum(cnt, 1.0)
        return acc / (cnt if acc.ndim == 1 else cnt[:, None])
    nd = vals.shape[0]
    max_id = int(mesh.node_ids[-1])
    if nd == max_id == n_node:  # ids 1..n without gaps: line k is node k
        return vals
    if nd == max_id:            # line k is node id k (ADH, MDAL): gaps in ids are skipped lines
        return vals[mesh.node_ids - 1]
    if nd == n_node:            # one line per node in ascending id order
        return vals
    raise ParseError(f"dataset {ds.name!r} has ND={nd} node values but the mesh {mesh.path.name} has {n_node} "
                     f"nodes (largest id {max_id}); adaptive ADH output (*.dat-<n>.<m>) needs its own mesh",
                     path=ds.path, line=ds.ts_lines[step])


def _ccw(mesh: MeshData) -> np.ndarray:
    """Faces reoriented anticlockwise (UGRID), by the signed area of the first three corners."""
    f = mesh.faces.copy()
    a, b, c = f[:, 0], f[:, 1], f[:, 2]
    area2 = (mesh.x[b] - mesh.x[a]) * (mesh.y[c] - mesh.y[a]) - (mesh.x[c] - mesh.x[a]) * (mesh.y[b] - mesh.y[a])
    cw = area2 < 0
    if cw.any():
        if f.shape[1] == 3:
            f[cw] = f[cw][:, ::-1]
        else:
            tri = cw & (f[:, 3] < 0)
            quad = cw & (f[:, 3] >= 0)
            f[tri, :3] = f[tri][:, 2::-1]
            f[quad] = f[quad][:, ::-1]
    return f


def open_adh(paths, *, units=None, crs=None, strict=False, time_units=None, plausibility="raise", roles=None,
             **unused):
    """ADH / SMS mesh + datasets → mesh snapshot (SI). See :func:`breachflow.io.open_snapshot`."""
    from ..units import ureg
    from ..field.snapshot import check_plausibility, mesh_snapshot
    from . import read_prj, unknown_options

    unknown_options("adh", unused)
    paths = [Path(p) for p in paths]
    meshes = [p for p in paths if p.suffix.lower() in MESH_EXTENSIONS]
    dats = [p for p in paths if p.suffix.lower() not in MESH_EXTENSIONS + (".bc", ".prj")]
    bcs = [p for p in paths if p.suffix.lower() == ".bc"]
    prjs = [p for p in paths if p.suffix.lower() == ".prj"]
    if len(meshes) != 1:
        raise InputError(f"ADH/SMS input needs exactly one mesh file (.3dm/.2dm), got {len(meshes)}: "
                         f"{', '.join(map(str, meshes)) or 'none'}")
    if len(bcs) > 1:
        raise InputError(f"at most one .bc file, got {len(bcs)}")
    bc = read_bc(bcs[0]) if bcs else None
    length_unit = _length_unit(units, bc)
    if units is None and length_unit == "ft" and (crs or prjs):
        # MP G tells feet but not which: a state plane in US survey feet (.prj / crs) says those
        from .asc import prj_length_unit

        if prj_length_unit(crs or read_prj(prjs[0])) == "survey_foot":
            length_unit = "survey_foot"
    mesh = read_mesh(meshes[0], strict=strict)
    to_m = float(ureg.Quantity(1.0, length_unit).to("m").magnitude)
    if not dats:
        return _terrain_only(mesh, to_m, length_unit, units, bc, crs or (read_prj(prjs[0]) if prjs else None),
                             [meshes[0], *bcs, *prjs], plausibility)
    datasets = [d for p in dats for d in read_dat(p, strict=strict)]
    roles, ignored = assign_roles(datasets, roles)
    if "depth" not in roles and "water_surface" not in roles:
        raise InputError("no depth or water-surface dataset among " + (", ".join(f"{d.name!r} ({d.path.name})" for d in datasets) or "no .dat files")
                         + "; ADH writes *_dep.dat (NAME \"Depth\"); name the roles with roles={'NAME or file': "
                         "'depth' | 'water_surface' | 'velocity' | 'ignore'}")
    scalar = roles.get("depth") or roles["water_surface"]
    vel = roles.get("velocity")
    t_override = None
    if time_units is not None:
        t_override = time_unit_seconds(time_units)
    elif bc is not None and bc.output_time_code is not None:
        t_override = None  # the .dat's own TIMEUNITS wins; AWRITE only fills a missing one below
    used = [d for d in (scalar, vel) if d is not None]
    times, time_notes = [], []
    for d in used:
        spu = t_override
        if spu is not None:
            note = f"{time_units} (time_units option)"
        elif d.time_units is not None and d.time_units_line == 0:
            note = f"{d.time_units} (binary SMS dataset without TIMEUNITS card: hours, as SMS and MDAL)"
        elif d.time_units is not None:
            where = f"line {d.time_units_line}" if d.time_units_line else "binary card 250"
            note = f"{d.time_units} (TIMEUNITS card, {d.path.name} {where})"
        elif bc is not None and bc.output_time_code is not None:
            spu = ADH_TIME_CODES[bc.output_time_code]
            note = f"{spu:g} s per unit (SERIES AWRITE output code {bc.output_time_code} in {bc.path.name})"
        else:
            note = (f"seconds by default: {d.path.name} has no TIMEUNITS card (ADH's own unit is the second; "
                    "MDAL/QGIS would assume hours for such a file)")
            if len(d.times) > 1:
                warnings.warn(f"{d.path}: no TIMEUNITS card and no .bc SERIES AWRITE: step times taken as seconds "
                              "(ADH's unit; MDAL/QGIS assume hours); pass time_units='hours' (or another unit) if the "
                              "file came from another tool", BreachflowWarning, stacklevel=2)
        time_notes.append(f"{d.path.name}: {note}")
        times.append(np.asarray(d.times, dtype=float) * d.seconds_per_unit(spu))
    nt = len(times[0])
    if vel is not None:
        nt = _align_times(scalar, vel, times[0], times[1])
    if nt == 0:
        raise ParseError(f"dataset {scalar.name!r} has no complete time step", path=scalar.path)
    bed = mesh.z * to_m
    n_node = mesh.node_ids.size
    depth = np.empty((nt, n_node))
    for k in range(nt):  # fill step by step, releasing the parsed step at once (peak memory)
        depth[k] = _node_values(scalar, mesh, k)
        scalar.values[k] = None
    if to_m != 1.0:
        depth *= to_m
    if scalar is not roles.get("depth"):
        depth -= bed[None, :]
    if vel is not None:
        u = np.empty((nt, n_node))
        v = np.empty((nt, n_node))
        for k in range(nt):
            uv = _node_values(vel, mesh, k)
            u[k] = uv[:, 0]
            v[k] = uv[:, 1]
            vel.values[k] = None
        if to_m != 1.0:
            u *= to_m
            v *= to_m
    else:
        warnings.warn("no velocity dataset: velocity set to zero", BreachflowWarning, stacklevel=2)
        u = v = np.zeros_like(depth)
    active = None
    if any(s is not None for s in scalar.status[:nt]):
        if scalar.nc != mesh.faces.shape[0]:
            raise ParseError(f"status flags for NC={scalar.nc} elements but the mesh has {mesh.faces.shape[0]}",
                             path=scalar.path, line=scalar.ts_lines[0])
        active = np.stack([s if s is not None else np.ones(mesh.faces.shape[0], np.int8) for s in scalar.status[:nt]])
    t = times[0][:nt]
    rt = scalar.rt_julian if scalar.rt_julian is not None else (vel.rt_julian if vel is not None else None)
    if rt is not None:
        epoch = (rt - 2440587.5) * 86400.0
        time = (np.round((epoch + t) * 1e3).astype("int64")).astype("datetime64[ms]").astype("datetime64[ns]")
    else:
        time = t
    crs_wkt = crs or (read_prj(prjs[0]) if prjs else None)
    files = [meshes[0], *[d.path for d in used], *bcs, *prjs]
    ds = mesh_snapshot(
        mesh.x * to_m, mesh.y * to_m, _ccw(mesh), bed, depth, u, v, time=time, crs_wkt=crs_wkt,
        source="ADH/SMS text export read by breachflow (reader 'adh')", source_files=[str(p) for p in files],
        node_ids=mesh.node_ids, face_ids=mesh.face_ids, face_material=mesh.material, face_active=active,
        copy=False,
    )
    ds.attrs.update(
        breachflow_reader="adh",
        source_length_unit=length_unit,
        source_length_unit_from=("user" if units else f"MP G {bc.gravity:g} in {bc.path.name}"
                                 + (" (US survey feet: the CRS's unit)" if length_unit == "survey_foot" else "")),
        source_datasets="; ".join(f"{role}: {d.name} ({d.path.name}, {len(d.times)} steps)" for role, d in roles.items()),
        source_time_units="; ".join(time_notes),
    )
    faces = [d for d in used if d.on_faces]
    if faces:
        ds.attrs["element_centred_datasets"] = "; ".join(
            f"{d.path.name}: {d.name} ({'NC value lines per step' if d.faces_from_count else '_els file name' if '_els' in d.path.stem.lower() else 'VECTYPE 1'}; "
            "averaged to the nodes)" for d in faces)
    if ignored:
        ds.attrs["ignored_datasets"] = "; ".join(ignored)
    if mesh.name:
        ds["mesh2d"].attrs["long_name"] = f"topology of the 2-D unstructured mesh {mesh.name}"
    partial = [d for d in used if d.partial_step_line is not None]
    if partial:
        ds.attrs["dropped_partial_steps"] = "; ".join(f"{d.path.name}:{d.partial_step_line}" for d in partial)
    locate = _locator(mesh, scalar, vel, scalar is roles.get("depth"))
    return check_plausibility(ds, mode=plausibility, raw_depth=depth, locate=locate)


def _terrain_only(mesh: MeshData, to_m, length_unit, units, bc, crs_wkt, files, plausibility):
    """A mesh without result datasets read as a terrain: bed z at the nodes, depth and velocity 0."""
    from ..field.snapshot import check_plausibility, mesh_snapshot

    n = mesh.node_ids.size
    zero = np.zeros(n)
    ds = mesh_snapshot(mesh.x * to_m, mesh.y * to_m, _ccw(mesh), mesh.z * to_m, zero, zero, zero.copy(), crs_wkt=crs_wkt,
                       source="ADH/SMS mesh read as a terrain by breachflow (reader 'adh')",
                       source_files=[str(p) for p in files], node_ids=mesh.node_ids, face_ids=mesh.face_ids,
                       face_material=mesh.material)
    ds.attrs.update(breachflow_reader="adh", breachflow_content="terrain: a mesh without result datasets (depth 0, velocity 0)",
                    source_length_unit=length_unit,
                    source_length_unit_from=("user" if units else f"MP G {bc.gravity:g} in {bc.path.name}"
                                             + (" (US survey feet: the CRS's unit)" if length_unit == "survey_foot" else "")))
    if mesh.name:
        ds["mesh2d"].attrs["long_name"] = f"topology of the 2-D unstructured mesh {mesh.name}"
    return check_plausibility(ds, mode=plausibility, locate=_locator(mesh, None, None, True))


def _dataset_row(ds: DatDataset, mesh: MeshData, node: int) -> int:
    """0-based value line within a step of node-centred *ds* holding mesh node index *node*."""
    if ds.nd == int(mesh.node_ids[-1]):  # as in _node_values: line k is node id k
        return int(mesh.node_ids[node]) - 1
    return node


def _locator(mesh: MeshData, scalar: DatDataset, vel: DatDataset | None, scalar_is_depth: bool):
    """``locate(key, index)`` for :func:`check_plausibility`: the file and line of a value at a node."""

    def value_line(ds: DatDataset, step: int, node: int):
        if ds.on_faces:  # element values averaged to the node: name the step and the elements' card lines
            touching = np.flatnonzero((mesh.faces == node).any(axis=1))
            note = ("element-centred values averaged to the node; elements on mesh lines "
                    + ", ".join(str(int(mesh.face_lines[f])) for f in touching[:6]) if mesh.face_lines is not None else "")
            first = ds.value_lines[step]
            return (str(ds.path), int(first + touching[0]) if touching.size else ds.ts_lines[step], note)
        if ds.value_lines[step] is None:  # binary dataset: no lines
            return (str(ds.path), None, f"binary dataset, time step {step}, value {_dataset_row(ds, mesh, node) + 1}")
        return (str(ds.path), int(ds.value_lines[step] + _dataset_row(ds, mesh, node)), "")

    def locate(key, idx):
        node = idx.get("node")
        if node is None:
            return None
        step = idx.get("time", 0)
        if key == "bed_elevation":
            return (str(mesh.path), int(mesh.node_lines[node]), "ND card") if mesh.node_lines is not None else None
        if key == "speed":
            return value_line(vel, step, node) if vel is not None and step < len(vel.value_lines) else None
        if scalar is None or step >= len(scalar.value_lines):
            return None
        path, line, note = value_line(scalar, step, node)
        if not scalar_is_depth and mesh.node_lines is not None:
            note = "; ".join(filter(None, [note, f"depth = water surface - bed of {mesh.path.name} line "
                                                 f"{int(mesh.node_lines[node])}"]))
        return path, line, note

    return locate


def _length_unit(units, bc: BcInfo | None) -> str:
    from ..units import ureg

    if units is not None:
        try:
            q = ureg.Quantity(1.0, str(units))
        except Exception:
            raise InputError(f"units={units!r}: not a length unit (use 'm' or 'ft')") from None
        if q.dimensionality != ureg.Quantity(1.0, "m").dimensionality:
            raise InputError(f"units={units!r}: not a length unit (use 'm' or 'ft')")
        if bc is not None and bc.length_unit and ureg.Quantity(1.0, str(units)).to("m").magnitude != ureg.Quantity(1.0, bc.length_unit).to("m").magnitude:
            warnings.warn(f"units={units!r} given but {bc.path.name}:{bc.gravity_line} has MP G {bc.gravity:g} "
                          f"(suggesting {bc.length_unit}); using {units!r}", BreachflowWarning, stacklevel=3)
        return str(units)
    if bc is not None and bc.length_unit:
        return bc.length_unit
    if bc is not None:
        raise InputError(f"{bc.path}: no MP G card (gravity), so metres cannot be told from feet; pass "
                         "units='m' or units='ft'")
    raise InputError("ADH/SMS files carry no units: pass units='m' or units='ft' (or include the model's .bc "
                     "file, whose MP G card tells metres from feet)")


def _align_times(a: DatDataset, b: DatDataset, ta: np.ndarray, tb: np.ndarray) -> int:
    n = min(ta.size, tb.size)
    if not np.allclose(ta[:n], tb[:n], rtol=1e-9, atol=1e-6):
        k = int(np.argmax(~np.isclose(ta[:n], tb[:n], rtol=1e-9, atol=1e-6)))
        raise ParseError(f"time step {k} of {a.name!r} is at t={ta[k]:g} s but {b.name!r} ({b.path.name}) "
                         f"has t={tb[k]:g} s: depth and velocity steps are inconsistent", path=a.path, line=a.ts_lines[k])
    if ta.size != tb.size:
        longer, shorter = (a, b) if ta.size > tb.size else (b, a)
        if shorter.partial_step_line is None and shorter.complete and longer.complete:
            raise ParseError(f"{a.name!r} has {ta.size} time steps but {b.name!r} ({b.path.name}) has {tb.size}",
                             path=a.path, line=a.ts_lines[-1] if a.ts_lines else None)
        warnings.warn(f"{longer.path.name} has {max(ta.size, tb.size)} steps, {shorter.path.name} {n}: "
                      f"using the {n} common step(s)", BreachflowWarning, stacklevel=3)
    return n
