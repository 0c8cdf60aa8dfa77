"""The ensemble result Dataset: one dimension per varied parameter (schema ``data_schemas/ensemble_result.json``).

Result variables come from the member runner (declared ``outputs`` and whatever members returned);
status variables say what happened to each member: ``member_status`` (0 ok, 1 failed, 2 not run),
``member_error_type``, ``member_error``, ``member_seed``, ``member_elapsed_time``, ``member_cpu_time``,
``member_run_dir``.
With ``replicates = N`` (N > 1) the last dimension is ``replicate`` (N placement seeds per parameter
combination, common random numbers) and :func:`replicate_reductions` adds, over the replicates of each
combination (members that ran): ``closure_probability`` (fraction closed inside the window, ``feasible``)
with its 95 % Wilson interval ``closure_probability_lower/upper`` and ``replicates_ok``, and the median
and 10 / 90 % quantiles of ``tonnage`` and ``closure_duration`` (``*_median``, ``*_p10``, ``*_p90``).
These variables carry ``ensemble_reduction = "replicate"`` and span the other dimensions.
Missing values (failed members): NaN for floats, the netCDF default fill value for integers and flags.
"""
from __future__ import annotations

import datetime as _dt
import hashlib
from pathlib import Path

import numpy as np
import xarray as xr

from .. import __version__
from ..atomic import atomic_path
from ..errors import InputError, SchemaError
from ..schemas import validate
from .spec import EnsembleSpec

STATUS_OK, STATUS_FAILED, STATUS_NOT_RUN = 0, 1, 2
STATUS_MEANINGS = "ok failed not_run"
INT_FILL = {"i1": -127, "i2": -32767, "i4": -2147483647, "i8": -9223372036854775806}
STATUS_VARIABLES = ("member_status", "member_error_type", "member_error", "member_seed", "member_elapsed_time",
                    "member_cpu_time", "member_run_dir")


def parameter_coordinates(spec: EnsembleSpec) -> dict[str, xr.DataArray]:
    """Coordinates of the varied parameters (SI values, ``units`` and ``long_name`` attributes)."""
    coords = {}
    dims = spec.dims
    for p in spec.parameters:
        values, unit = p.si
        attrs = {"long_name": p.long_name or f"scenario parameter {p.dotted} varied across the ensemble",
                 "scenario_parameter": p.dotted,
                 "values_as_given": ", ".join(str(v) for v in p.values)}
        if unit:
            attrs["units"] = unit
            given = {_unit_of(v) for v in p.values} - {None}
            if len(given) == 1 and (g := given.pop()) != unit:
                attrs["display_units"] = g
        if isinstance(values[0], bool):
            arr = np.asarray(values, dtype="i1")
            attrs.update(flag_values=np.array([0, 1], dtype="i1"), flag_meanings="false true")
        elif isinstance(values[0], str):
            arr = _strings(values)
        else:
            arr = np.asarray(values, dtype=float)
        dim = p.name if spec.design == "factorial" else dims[0]
        coords[p.name] = xr.DataArray(arr, dims=(dim,), attrs=attrs)
    if spec.design == "members":
        coords["member"] = xr.DataArray(np.arange(spec.shape[0]), dims=("member",),
                                        attrs={"long_name": "ensemble member number (order of [[ensemble.members]])",
                                               "units": "1"})
    if spec.replicates > 1:
        coords["replicate"] = xr.DataArray(np.arange(spec.replicates), dims=("replicate",), attrs={
            "long_name": "replicate number (placement seed; the same seeds in every parameter combination)",
            "units": "1"})
    return coords


def _unit_of(value):
    from .spec import looks_like_quantity
    from ..units import Q_

    if looks_like_quantity(value):
        try:
            return f"{Q_(value).units:~}".replace(" ", "").replace("**", "^")
        except Exception:
            return None
    return None


def build_dataset(spec: EnsembleSpec, records: list[dict], runner_cls, *, out_dir: Path | None = None) -> xr.Dataset:
    """Assemble member *records* (one per member, in member order) into the result Dataset."""
    shape, dims = spec.shape, spec.dims
    n = len(records)
    if int(np.prod(shape)) != n:
        raise InputError(f"ensemble: {n} records for a grid of shape {shape}")
    declared = dict(getattr(runner_cls, "outputs", {}) or {})
    optional = set(getattr(runner_cls, "optional_outputs", ()) or ())
    ok = [r for r in records if r.get("status") == "ok"]
    seen: dict[str, dict] = {}
    for r in ok:
        for name, rv in r.get("results", {}).items():
            info = seen.setdefault(name, {"kind": rv["kind"], "units": rv.get("units", "")})
            if info["kind"] != rv["kind"] or info["units"] != rv.get("units", ""):
                raise InputError(f"ensemble result {name!r}: member {r['key']} gives {rv['kind']} in "
                                 f"{rv.get('units')!r}, others {info['kind']} in {info['units']!r}")
    names = [k for k in declared if k in seen or k not in optional] + sorted(k for k in seen if k not in declared)

    data_vars = {}
    for name in names:
        decl = declared.get(name, {})
        kind = seen.get(name, {}).get("kind") or _kind_of_dtype(decl.get("dtype", "f8"))
        units = seen.get(name, {}).get("units") if name in seen else decl.get("units", "1" if kind in ("float", "int") else "")
        dtype = decl.get("dtype") or {"float": "f8", "int": "i8", "bool": "i1", "str": "str"}[kind]
        if kind == "bool":
            dtype = "i1"
        attrs = {k: v for k, v in decl.items() if k not in ("dtype", "units")}
        attrs.setdefault("long_name", name.replace("_", " "))
        if kind == "float":
            arr = np.full(n, np.nan)
            encoding = {}
        elif kind in ("int", "bool"):
            fill = INT_FILL.get(np.dtype(dtype).str[1:], INT_FILL["i8"])
            arr = np.full(n, fill, dtype=dtype)
            encoding = {"_FillValue": fill}
            if kind == "bool":
                attrs.update(flag_values=np.array([0, 1], dtype="i1"), flag_meanings="false true")
            elif "flag_values" in attrs:
                attrs["flag_values"] = np.asarray(attrs["flag_values"], dtype=dtype)
        else:
            arr = np.full(n, "", dtype=object)
            encoding = {}
        for i, r in enumerate(records):
            if r.get("status") == "ok" and name in r.get("results", {}):
                v = r["results"][name]["value"]
                arr[i] = float(v) if kind == "float" else (int(v) if kind in ("int", "bool") else str(v))
        if kind == "str":
            arr = _strings(arr)
        if units and kind in ("float", "int"):
            attrs["units"] = units
        var = xr.Variable(dims, arr.reshape(shape), attrs)
        var.encoding.update(encoding)
        data_vars[name] = var

    status = np.array([{"ok": STATUS_OK, "failed": STATUS_FAILED}.get(r.get("status"), STATUS_NOT_RUN) for r in records],
                      dtype="i1")
    rel = [_relative(r.get("run_dir", ""), out_dir) for r in records]
    data_vars["member_status"] = xr.Variable(dims, status.reshape(shape), {
        "long_name": "outcome of the member run", "flag_values": np.array([0, 1, 2], dtype="i1"),
        "flag_meanings": STATUS_MEANINGS})
    data_vars["member_error_type"] = xr.Variable(dims, _strings([r.get("error_type") or "" for r in records]).reshape(shape),
                                                 {"long_name": "exception type of a failed member ('' if ok)"})
    data_vars["member_error"] = xr.Variable(dims, _strings([r.get("error_message") or "" for r in records]).reshape(shape),
                                            {"long_name": "error message of a failed member ('' if ok)"})
    data_vars["member_seed"] = xr.Variable(dims, np.array([int(r.get("seed", 0)) for r in records], dtype="i8").reshape(shape),
                                           {"long_name": "random seed of the member (hash of its parameter values)",
                                            "units": "1"})
    data_vars["member_elapsed_time"] = xr.Variable(dims, np.array([float(r.get("elapsed", np.nan)) for r in records]).reshape(shape),
                                                   {"long_name": "wall-clock time of the member run", "units": "s"})
    data_vars["member_cpu_time"] = xr.Variable(dims, np.array([float(r.get("cpu_time", np.nan)) for r in records]).reshape(shape),
                                               {"long_name": "CPU time of the thread that ran the member", "units": "s"})
    data_vars["member_run_dir"] = xr.Variable(dims, _strings(rel).reshape(shape),
                                              {"long_name": "member run directory (relative to the ensemble output directory)"})
    ds = xr.Dataset(data_vars, coords=parameter_coordinates(spec))
    n_failed = int((status == STATUS_FAILED).sum())
    ds.attrs = {
        "Conventions": "CF-1.8",
        "title": f"breachflow ensemble: {spec.name}",
        "source": f"breachflow {__version__}, member runner {spec.runner!r}",
        "history": f"{_dt.datetime.now(_dt.timezone.utc).isoformat(timespec='seconds')} breachflow.ensemble.run",
        "references": "SERRI Report 70015-001 (2009); breachflow docs/theory.md",
        "ensemble_name": spec.name,
        "ensemble_runner": spec.runner,
        "ensemble_design": spec.design,
        "ensemble_dimensions": " ".join(spec.dims),
        "ensemble_members": n,
        "ensemble_failed": n_failed,
        "ensemble_not_run": int((status == STATUS_NOT_RUN).sum()),
        "ensemble_seed": spec.seed,
        "ensemble_spec_sha256": hashlib.sha256(spec.to_toml().encode()).hexdigest(),
    }
    if spec.description:
        ds.attrs["comment"] = spec.description
    if spec.replicates > 1:
        ds.attrs["ensemble_replicates"] = spec.replicates
        ds = replicate_reductions(ds)
    return ds


#: quantities summarised over the replicates by their median and 10 / 90 % quantiles
REPLICATE_QUANTILES = ("tonnage", "closure_duration")


def wilson_interval(k, n, confidence: float = 0.95):
    """Wilson score interval of a binomial proportion ``k / n`` (arrays; NaN where n = 0), by
    ``scipy.stats.binomtest(k, n).proportion_ci(method="wilson")``."""
    from scipy.stats import binomtest

    k = np.asarray(k, int)
    n = np.asarray(n, int)
    lo = np.full(k.shape, np.nan)
    hi = np.full(k.shape, np.nan)
    for idx in np.ndindex(k.shape):
        if n[idx] > 0:
            ci = binomtest(int(k[idx]), int(n[idx])).proportion_ci(confidence_level=confidence, method="wilson")
            lo[idx], hi[idx] = ci.low, ci.high
    return lo, hi


def replicate_reductions(ds: xr.Dataset) -> xr.Dataset:
    """Add the reductions over ``replicate`` (see the module docstring) to a result Dataset."""
    def fresh(da, **attrs):  # a reduction's own attributes only (none inherited from its operands)
        da = da.copy()
        da.attrs = {**attrs, "ensemble_reduction": "replicate"}
        da.encoding = {}
        return da

    ok = ds["member_status"] == STATUS_OK
    n = ok.sum("replicate")
    ds["replicates_ok"] = fresh(n.astype("i8"), long_name="replicates that ran (member_status ok)", units="1")
    flag = "feasible" if "feasible" in ds else ("closure_achieved" if "closure_achieved" in ds else None)
    if flag is not None:
        closed = ((ds[flag] == 1) & ok).sum("replicate")
        p = xr.where(n > 0, closed / n.where(n > 0), np.nan)
        what = "inside the closure window" if flag == "feasible" else "within the cycle limit"
        ds["closure_probability"] = fresh(p.astype(float), long_name=f"probability of closure {what} (over replicates)",
                                          units="1")
        lo, hi = wilson_interval(closed.values, n.values)
        for name, arr, side in (("closure_probability_lower", lo, "lower"), ("closure_probability_upper", hi, "upper")):
            ds[name] = fresh(xr.DataArray(arr, dims=p.dims),
                             long_name=f"{side} bound of the 95 % Wilson interval of closure_probability", units="1")
    for name in REPLICATE_QUANTILES:
        if name not in ds:
            continue
        v = ds[name].where(ok)
        units = ds[name].attrs.get("units", "1")
        # shown in the unit of the quantity itself (tonnage in t, durations in h), not in its SI unit
        shown = {"display_units": ds[name].attrs["display_units"]} if "display_units" in ds[name].attrs else {}
        ds[f"{name}_median"] = fresh(v.median("replicate"), long_name=f"median over replicates of {name}", units=units,
                                     **shown)
        for q in (10, 90):
            ds[f"{name}_p{q}"] = fresh(v.quantile(q / 100, "replicate").drop_vars("quantile"),
                                       long_name=f"{q} % quantile over replicates of {name}", units=units, **shown)
    return ds


def _strings(values) -> np.ndarray:
    """Unicode array (numpy ``U``; written as NetCDF-4 strings). Never zero-width."""
    arr = np.asarray([str(v) for v in values], dtype=str)
    return arr if arr.dtype.itemsize else arr.astype("U1")


def _kind_of_dtype(dtype: str) -> str:
    if dtype == "bool":
        return "bool"
    if dtype == "str":
        return "str"
    return "int" if dtype.startswith("i") else "float"


def _relative(run_dir: str, out_dir: Path | None) -> str:
    if not run_dir:
        return ""
    if out_dir is None:
        return str(run_dir)
    try:
        return str(Path(run_dir).resolve().relative_to(Path(out_dir).resolve()))
    except ValueError:
        return str(run_dir)


def validate_result(ds: xr.Dataset, *, source: str | None = None) -> xr.Dataset:
    """Check *ds* against ``data_schemas/ensemble_result.json`` and the structural rules the JSON schema
    cannot express: every data variable spans exactly the ensemble dimensions; every numeric result and
    varied-parameter coordinate has ``units`` (or flag attributes)."""
    validate(ds, "ensemble_result", source=source)
    dims = tuple(str(ds.attrs["ensemble_dimensions"]).split())
    problems = []
    for name, var in ds.data_vars.items():
        want = dims
        if var.attrs.get("ensemble_reduction") == "replicate":
            want = tuple(d for d in dims if d != "replicate")
        elif var.attrs.get("ensemble_per_cycle") == "cycle":  # breachflow.ensemble.cycles
            want = (*dims, "cycle")
        if tuple(var.dims) != want:
            problems.append(f"{name}: dims {tuple(var.dims)}, expected the ensemble dimensions {want}")
        if np.issubdtype(var.dtype, np.number) and "units" not in var.attrs and "flag_values" not in var.attrs:
            problems.append(f"{name}: numeric variable without 'units' or flag attributes")
        if "long_name" not in var.attrs:
            problems.append(f"{name}: missing attribute 'long_name'")
    for name, coord in ds.coords.items():
        if "scenario_parameter" in coord.attrs and np.issubdtype(coord.dtype, np.floating) and "units" not in coord.attrs:
            problems.append(f"{name}: parameter coordinate without 'units'")
    if problems:
        head = f"{source}: " if source else ""
        raise SchemaError(f"{head}Dataset does not match schema 'ensemble_result':\n  - " + "\n  - ".join(problems))
    return ds


def write_result(ds: xr.Dataset, path) -> Path:
    """Validate and write the result Dataset to NetCDF atomically (never a half-written file)."""
    path = Path(path)
    validate_result(ds, source=str(path))
    from ..provenance import stamp

    ds = stamp(ds)  # breachflow version, git commit, command (one helper for every writer)
    from ..io.cf import cf_text_coordinates, string_encoding

    ds = cf_text_coordinates(ds)
    with atomic_path(path, suffix=".nc") as tmp:
        ds.to_netcdf(tmp, engine="netcdf4", encoding=string_encoding(ds))
    return path


def open_result(path) -> xr.Dataset:
    """Open an ensemble result NetCDF (loaded into memory, file closed) in the representation
    :func:`breachflow.ensemble.run` returns: integer flags with their fill value, ``str`` arrays.
    (``xr.open_dataset`` works too; it decodes masked integers to float with NaN.)"""
    from ..io.cf import restore_text_coordinates

    with xr.open_dataset(path) as ds:
        ds = restore_text_coordinates(ds.load())
    for name, var in list(ds.variables.items()):
        if var.dtype == object:  # NetCDF-4 strings come back as objects
            ds[name] = var.astype(str)
        disk = np.dtype(var.encoding.get("dtype", var.dtype))
        if disk.kind == "i" and var.dtype.kind == "f" and "_FillValue" in var.encoding:
            # masked integers/flags were decoded to float with NaN: back to run()'s representation
            fill = var.encoding["_FillValue"]
            ds[name] = var.fillna(fill).astype(disk)
            ds[name].attrs = dict(var.attrs)
            ds[name].encoding.update(_FillValue=fill)
    return ds
