"""Output: atomic CF NetCDF writes, particle and trajectory Datasets, run directories (docs/theory.md, *The closure cycle*)."""
from .atomic import atomic_write_json, atomic_write_netcdf, atomic_write_text
from .cf import TIME_UNITS, netcdf_encoding, particles_dataset, trajectories_dataset
from .rundir import RunDirectory

__all__ = ["atomic_write_json", "atomic_write_netcdf", "atomic_write_text", "TIME_UNITS", "netcdf_encoding",
           "particles_dataset", "trajectories_dataset", "RunDirectory"]
