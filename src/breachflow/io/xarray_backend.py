"""breachflow's snapshot readers as an xarray backend (engine ``"breachflow"``).

>>> import xarray as xr
>>> ds = xr.open_dataset("RASExport.sdf", engine="breachflow")             # doctest: +SKIP
>>> ds = xr.open_dataset("depth.asc", engine="breachflow", units="ft")      # doctest: +SKIP

xarray finds the engine through the entry point group ``xarray.backends`` (declared in pyproject.toml), as
it finds cfgrib's and rioxarray's. Opening delegates to :func:`breachflow.io.open_snapshot`: the
result is the same validated SI snapshot Dataset. A snapshot that needs several files (an ADH mesh with its
``.dat`` datasets and ``.bc``) is opened from its mesh file: the companions named ``STEM_*.dat`` and
``STEM.bc`` beside it are found by name, or pass them as ``companions=[...]``; or call
:func:`~breachflow.io.open_snapshot` with the list.
"""
from __future__ import annotations

from pathlib import Path

from xarray.backends import BackendEntrypoint

#: the extensions :meth:`BreachflowBackendEntrypoint.guess_can_open` claims (``.dat``, ``.bc``, ``.prj``,
#: ``.hdf`` and ``.asc`` are left to the caller's ``engine=``: other programs write files of those names)
CLAIMED_EXTENSIONS = (".3dm", ".2dm", ".sdf")


def _companions(path: Path) -> list[Path]:
    """The ``.dat`` datasets and ``.bc`` file that SMS / ADH write beside a ``.3dm`` / ``.2dm`` mesh."""
    if path.suffix.lower() not in (".3dm", ".2dm"):
        return []
    found = sorted(path.parent.glob(f"{path.stem}_*.dat"))
    bc = path.with_suffix(".bc")
    return found + ([bc] if bc.exists() else [])


class BreachflowBackendEntrypoint(BackendEntrypoint):
    """``xr.open_dataset(path, engine="breachflow")``: ADH / SMS meshes and datasets, HEC-RAS ``.sdf`` and
    HEC-RAS 6 HDF files, ESRI ASCII grids, read by breachflow's readers into an SI snapshot Dataset."""

    description = "ADH/SMS, HEC-RAS (.sdf, HDF) and ESRI ASCII model results as breachflow snapshots (SI, CF)"
    open_dataset_parameters = ("filename_or_obj", "drop_variables", "format", "units", "crs", "companions",
                               "plausibility", "options")

    def open_dataset(self, filename_or_obj, *, drop_variables=None, format=None, units=None, crs=None,
                     companions=None, plausibility="raise", **options):
        """Open *filename_or_obj* (and its *companions*) as :func:`~breachflow.io.open_snapshot` does;
        *options* are the reader's own (``bed=``, ``roles=``, ``mesh_name=``, ``time_units=``, ...)."""
        from . import open_snapshot
        from ..errors import InputError

        if not isinstance(filename_or_obj, (str, Path)):
            raise InputError("engine 'breachflow' opens files by path, not file objects or stores")
        path = Path(filename_or_obj)
        paths = [path, *(map(Path, companions) if companions is not None else _companions(path))]
        ds = open_snapshot(paths, format=format, units=units, crs=crs, plausibility=plausibility, **options)
        if drop_variables:
            ds = ds.drop_vars(drop_variables, errors="ignore")
        return ds

    def guess_can_open(self, filename_or_obj) -> bool:
        """True for the extensions only breachflow's readers claim (:data:`CLAIMED_EXTENSIONS`)."""
        try:
            return Path(filename_or_obj).suffix.lower() in CLAIMED_EXTENSIONS
        except TypeError:
            return False
