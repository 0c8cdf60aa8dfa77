"""The grid snapshot constructor and the levee/breach geometry objects."""
import numpy as np
import pytest

from breachflow import InputError
from breachflow.errors import SchemaError
from breachflow.field.snapshot import grid_snapshot, set_crs
from breachflow.schemas import validate
from breachflow.scenario import BreachGeometry, LeveeGeometry, typical_breach


def test_grid_snapshot_masks_dry_cells_and_validates():
    x = np.arange(3.0)
    y = np.arange(2.0)
    bed = np.zeros((2, 3))
    depth = np.array([[0.0, 1.0, 2.0], [0.5, 0.0, 1.0]])
    u = np.ones((2, 3))
    ds = grid_snapshot(x, y, bed, depth, u, 2 * u, crs_wkt='LOCAL_CS["test"]')
    assert ds.u.values[0, 0] == 0 and ds.v.values[1, 1] == 0 and ds.u.values[0, 1] == 1
    np.testing.assert_array_equal(ds.wet.values, depth > 0)
    np.testing.assert_allclose(ds.water_surface.values, bed + depth)
    assert ds.depth.attrs["grid_mapping"] == "crs"
    ds["depth"].attrs["units"] = "ft"
    with pytest.raises(SchemaError, match="units 'ft'"):
        validate(ds, "snapshot_grid")


def test_levee_area_and_breach_bottom():
    lev = LeveeGeometry.from_input(height="25 ft", crown_width="15 ft", flood_slope=3, protected_slope=3)
    h = 25 * 0.3048
    assert lev.area == pytest.approx(h * (15 * 0.3048 + 3 * h))
    br = BreachGeometry.from_input(length="60 m", depth="6 m", wall_slope=0.5)
    assert br.bottom_width == pytest.approx(54.0)
    assert br.flow_area(2.0) == pytest.approx(2.0 * (54.0 + 1.0))
    with pytest.raises(InputError, match="meet above the bottom"):
        BreachGeometry(length=5.0, depth=6.0, wall_slope=0.5)
    with pytest.raises(InputError, match="unknown parameter"):
        LeveeGeometry.from_input(hieght="2 m")


def test_typical_breach_preset_matches_report():
    s = typical_breach()
    assert s.surge_height == pytest.approx(7.6)
    assert s.breach.length == 61.0 and s.levee.flood_slope == 4.0 and s.manning_n == 0.025
