"""Pre-event breach atlas of a levee district: where would a breach hurt most, how large would it grow, how
long would there be to close it, and could it be closed with the methods at hand.

    from breachflow.atlas import run_atlas
    ds = run_atlas("examples/district/district.toml", "runs/district")          # local dask cluster
    ds = run_atlas("district.toml", "runs/d", scheduler="tcp://10.0.0.5:8786")  # an existing scheduler

The command line: ``breachflow atlas DISTRICT.toml --out DIR [--scheduler ADDRESS] [--workers N]``.
The district file is described in :mod:`breachflow.atlas.config`; the screening figures in
:mod:`breachflow.atlas.screening`; the outputs in :mod:`breachflow.atlas.outputs`.
"""
from .config import ClosureMethod, District, load_district
from .execute import plan, run_atlas
from .locations import Location, locate
from .screening import screen

__all__ = ["ClosureMethod", "District", "Location", "load_district", "locate", "plan", "run_atlas", "screen"]
