"""The ensemble summary shows the replicate quantiles in the unit of their quantity (tonnage in t,
durations in h), as it shows the members' own values, and the varied parameters with their unit."""
import numpy as np
import xarray as xr
from rich.console import Console

from breachflow.cli.ensemble import summary_table
from breachflow.ensemble.dataset import STATUS_OK, replicate_reductions


def _ensemble():
    tonnage = np.array([[200e3, 240e3, 280e3], [300e3, 300e3, 300e3]])     # kg
    duration = np.array([[1800.0, 3600.0, 5400.0], [7200.0, 7200.0, 7200.0]])  # s
    dims = ("mass_size", "replicate")
    return xr.Dataset(
        {"member_status": (dims, np.full((2, 3), STATUS_OK)),
         "closure_achieved": (dims, np.array([[1, 0, 1], [1, 1, 1]])),
         "tonnage": (dims, tonnage, {"units": "kg", "display_units": "t", "long_name": "total mass placed"}),
         "closure_duration": (dims, duration, {"units": "s", "display_units": "h"})},
        coords={"mass_size": ("mass_size", [1.8, 2.2], {"units": "m"}), "replicate": [0, 1, 2]},
        attrs={"title": "test ensemble"})


def test_replicate_quantiles_keep_their_quantitys_display_unit_in_the_summary():
    ds = replicate_reductions(_ensemble())
    for q in ("median", "p10", "p90"):
        assert ds[f"tonnage_{q}"].attrs["units"] == "kg" and ds[f"tonnage_{q}"].attrs["display_units"] == "t"
        assert ds[f"closure_duration_{q}"].attrs["display_units"] == "h"
    con = Console(record=True, width=200)
    con.print(summary_table(ds))
    text = con.export_text()
    rows = {line.split("│")[1].strip(): [c.strip() for c in line.split("│")[2:-1]]
            for line in text.splitlines() if line.count("│") >= 5}
    # medians over the replicates: 240 t and 300 t; 1 h and 2 h (by hand from the arrays above)
    assert rows["tonnage_median"] == ["240", "300", "t"], rows["tonnage_median"]
    assert rows["closure_duration_median"] == ["1", "2", "h"], rows["closure_duration_median"]
    assert rows["tonnage"] == ["200", "300", "t"]
    assert "mass_size (m)" in text
