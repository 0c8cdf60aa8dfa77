"""Readers of hydrodynamic model exports, by name (registry ``breachflow.readers``, like xarray backends).

>>> ds = open_snapshot(["run.3dm", "run_dep.dat", "run_vel.dat", "run.bc"])       # doctest: +SKIP
>>> ds = open_snapshot(["depth.asc", "velocity.asc"], units="ft", bed="0 ft")        # doctest: +SKIP

Built-in readers (a reader is a class with one method ``open(paths, **options) -> xr.Dataset``):

``adh``     ADH / SMS ``.3dm``/``.2dm`` mesh + ``.dat`` datasets (+ ``.bc`` for units, ``.prj``) → mesh snapshot
``sdf``     HEC-RAS GIS export ``.sdf`` (cross sections) → mesh snapshot over the cut lines
``asc``     ESRI ASCII grids (``.asc`` + ``.prj``) of depth / velocity / water surface / terrain → grid snapshot
``hecras_hdf`` HEC-RAS 6 HDF plan (+ geometry) files via the optional ``rashdf`` → mesh over the cell centres

Third-party readers register through the ``breachflow.readers`` entry point group.

Writers (the other direction, :mod:`breachflow.io.writers`, :mod:`breachflow.io.sdf_writer`):
``write_adh(snapshot, prefix)``, ``write_esri(snapshot, prefix)``, ``write_sdf(snapshot, path)``,
``write_hecras_hdf(snapshot, path)`` (:mod:`breachflow.io.hecras_hdf_writer`, a HEC-RAS 6 2-D plan HDF);
:func:`~breachflow.io.meshing.to_unaligned_mesh` puts a grid snapshot on an unaligned triangle mesh
(:mod:`breachflow.io.meshing`).

Every reader converts to SI once (pint), validates against the snapshot schema and runs the
plausibility checks (``plausibility="raise" | "warn" | "off"``).
"""
from __future__ import annotations

from pathlib import Path

import xarray as xr

from ..errors import InputError
from ..registry import Registry

READERS: Registry = Registry("snapshot reader", "breachflow.readers")


def unknown_options(reader: str, options: dict) -> None:
    if options:
        raise InputError(f"reader {reader!r} does not take option(s) {', '.join(sorted(options))}")


def read_prj(path) -> str:
    """The WKT text of an ESRI ``.prj`` file (one line of WKT1)."""
    from ..errors import ParseError

    try:
        text = Path(path).read_text(encoding="utf-8", errors="replace").strip()
    except OSError as exc:
        raise ParseError(f"cannot read projection file ({exc.strerror})", path=path) from None
    if not text or "[" not in text:
        raise ParseError("not a WKT projection (.prj) file", path=path, line=1)
    return text


@READERS.register("adh")
class AdhReader:
    """ADH / SMS meshes and ASCII datasets."""

    extensions = (".3dm", ".2dm", ".dat", ".bc")

    def open(self, paths, **options) -> xr.Dataset:
        from .adh import open_adh

        return open_adh(paths, **options)


@READERS.register("sdf")
class SdfReader:
    """HEC-RAS GIS export (RASExport.sdf)."""

    extensions = (".sdf",)

    def open(self, paths, **options) -> xr.Dataset:
        from .sdf import open_sdf

        return open_sdf(paths, **options)


@READERS.register("asc")
class AscReader:
    """ESRI ASCII grids (RAS Mapper maps converted with GDAL, LISFLOOD-FP results, ...)."""

    extensions = (".asc", ".wd", ".elev", ".vx", ".vy", ".dem")

    def open(self, paths, **options) -> xr.Dataset:
        from .asc import open_asc

        return open_asc(paths, **options)


@READERS.register("hecras_hdf")
class HecRasHdfReader:
    """HEC-RAS 6 HDF plan / geometry files (via rashdf; optional extra ``breachflow[hecras]``)."""

    extensions = (".hdf", ".h5", ".hdf5")

    def open(self, paths, **options) -> xr.Dataset:
        from .hecras_hdf import open_hecras_hdf

        return open_hecras_hdf(paths, **options)


def guess_format(paths, roles=None) -> str:
    """Reader name from the files' extensions (``.prj`` and ``.bc`` are companions, not decisive).

    Grids with another extension (LISFLOOD-FP ``.wd``/``.elev``/``.Vx``, ``.txt``) are ESRI grids when
    their extension is a LISFLOOD-FP one or every file is named in *roles*.
    """
    from .asc import SUFFIX_ROLES

    exts = {Path(p).suffix.lower() for p in paths} - {".prj"}
    for name in READERS.available():
        cls = READERS.get(name)
        primary = [e for e in getattr(cls, "extensions", ()) if e not in (".bc", ".dat")]
        if exts & set(primary):
            return name
    named = {Path(k).name for k in (roles or {})}
    grids = [Path(p) for p in paths if Path(p).suffix.lower() != ".prj"]
    if grids and all(p.suffix.lower() in SUFFIX_ROLES or p.name in named for p in grids):
        return "asc"
    raise InputError(f"cannot tell the format of {', '.join(map(str, paths))} from the extension(s); "
                     f"pass format= one of {', '.join(READERS.available())}")


def open_snapshot(paths, format: str | None = None, units=None, crs: str | None = None, *,
                  plausibility: str = "raise", **options) -> xr.Dataset:
    """Read model output files into a validated SI snapshot Dataset (grid or UGRID mesh).

    *paths*: a file or a list of files that together form one snapshot (mesh + datasets + .bc;
    several .asc grids; one .sdf). *format*: reader name (default: from the extensions).
    *units*: the length unit of files that carry none (``"m"``, ``"ft"``; velocities are then in
    unit/s). *crs*: ``EPSG:nnnn``, WKT or a PROJ string overriding a ``.prj`` or header; it (or the
    files' CRS) must be in the files' length unit and is stored as WKT (re-expressed in metres). Reader-specific *options* are documented in
    each reader module (e.g. ``strict=True`` rejects unknown cards; ``time_units=`` for .dat files;
    ``roles={"NAME or file": "depth" | "water_surface" | "velocity" | "ignore"}`` for .dat datasets and
    ``roles={"file": "depth" | "water_surface" | "bed" | "u" | "v" | "speed"}`` for grids;
    ``mesh_name=`` for HEC-RAS HDF). A mesh, geometry HDF or terrain grid alone reads as a terrain.
    """
    if isinstance(paths, (str, Path)):
        paths = [paths]
    paths = [Path(p) for p in paths]
    if not paths:
        raise InputError("open_snapshot: no files given")
    for p in paths:
        if not p.exists():
            raise InputError(f"file {str(p)!r} does not exist")
    name = format or guess_format(paths, options.get("roles"))
    reader = READERS.create(name)
    if crs is not None:
        from ..field.crs import resolve_crs

        crs = resolve_crs(crs, where="crs", data_unit=None, metres=False)
    ds = reader.open(paths, units=units, crs=crs, plausibility=plausibility, **options)
    if "crs" in ds.variables:
        # the CRS (given or from the files) as WKT GDAL reads, checked against the files' length unit and
        # expressed in metres like the coordinates
        from ..field.crs import resolve_crs
        from ..field.snapshot import set_crs

        unit = ds.attrs.get("source_length_unit") or "m"
        set_crs(ds, resolve_crs(ds["crs"].attrs["crs_wkt"], data_unit=unit,
                                where="crs" if crs is not None else f"CRS of {', '.join(p.name for p in paths)}"))
    return ds


def __getattr__(name):  # writers and mesh tools import lazily
    if name in ("write_adh", "write_esri", "ESRI_ROLES"):
        from . import writers

        return getattr(writers, name)
    if name == "write_sdf":
        from .sdf_writer import write_sdf

        return write_sdf
    if name == "write_hecras_hdf":
        from .hecras_hdf_writer import write_hecras_hdf

        return write_hecras_hdf
    if name in ("to_unaligned_mesh", "grid_to_mesh"):
        from . import meshing

        return getattr(meshing, name)
    if name in ("TIME_UNITS", "netcdf_encoding", "particles_dataset", "trajectories_dataset"):
        from . import cf

        return getattr(cf, name)
    if name == "RunDirectory":
        from .rundir import RunDirectory

        return RunDirectory
    raise AttributeError(name)


__all__ = ["READERS", "open_snapshot", "guess_format", "read_prj", "write_adh", "write_esri", "write_sdf",
           "write_hecras_hdf", "to_unaligned_mesh", "grid_to_mesh",
           "TIME_UNITS", "netcdf_encoding", "particles_dataset", "trajectories_dataset", "RunDirectory"]
