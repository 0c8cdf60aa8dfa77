"""End criteria (docs/theory.md, *The closure cycle*) on fields with hand-computable values."""
import numpy as np
import pytest

from breachflow import InputError, UnitError
from breachflow.cycle.criteria import CycleContext, EndCriteria, criteria
from breachflow.field.snapshot import grid_snapshot

DX = 0.5


def field(depth=2.0, u=1.0, v=0.0, slope=0.0, nx=41, ny=21):
    x = np.arange(nx) * DX - 10.0
    y = np.arange(ny) * DX - 5.0
    X, Y = np.meshgrid(x, y)
    bed = -slope * X
    return grid_snapshot(x, y, bed, np.full(X.shape, depth), np.full(X.shape, u), np.full(X.shape, v))


def ctx(snapshot, **kw):
    base = dict(cycle=1, snapshot=snapshot, breach_x=(-5.0, 5.0), levee_y=0.0, flood_level=2.0, bottom=0.0)
    base.update(kw)
    return CycleContext(**base)


def test_max_speed_and_units():
    c = criteria.get("max_speed")("0.2 m/s")
    r = c.evaluate(ctx(field(u=3.0, v=4.0)))
    assert r.value == pytest.approx(5.0) and not r.satisfied
    assert criteria.get("max_speed")("20 ft/s").evaluate(ctx(field(u=3.0, v=4.0))).satisfied  # 6.1 m/s > 5
    with pytest.raises(UnitError, match="criteria.max_speed"):
        criteria.get("max_speed")("3 m")


def test_discharge_proxy_equals_speed_times_wetted_section():
    # uniform h=2, U=1.5 over a 10 m wide box (21 cells of 0.5 m from -5 to 5): 1.5 * 2 * 21 * 0.5
    c = criteria.get("discharge_proxy")("1 m3/s")
    assert c.evaluate(ctx(field(depth=2.0, u=1.5))).value == pytest.approx(1.5 * 2.0 * 21 * DX)
    # obstacles across half the box halve the open area
    ds = field(depth=2.0, u=1.5)
    ob = np.zeros(ds.depth.shape, "i1")
    ob[:, ds.x.values < 0] = 1
    ds["obstacle"] = (("y", "x"), ob, {"units": "1"})
    assert c.evaluate(ctx(ds)).value == pytest.approx(1.5 * 2.0 * 11 * DX)


def test_head_gradient_of_a_sloping_still_surface():
    # still water over a sloping bed with constant depth: eta slope = bed slope
    c = criteria.get("head_gradient")(1e-3)
    r = c.evaluate(ctx(field(u=0.0, slope=0.01)))
    assert r.value == pytest.approx(0.01, rel=1e-9) and not r.satisfied


def test_blocked_fraction_of_one_sphere_in_the_section():
    r = 0.8
    pos = np.array([[0.0, 0.3, 1.0]])  # 0.3 m off the centreline: section radius sqrt(r^2-0.09)
    c = criteria.get("blocked_fraction")(0.5)
    res = c.evaluate(ctx(field(), pos=pos, radius=np.array([r]), resting=np.array([True])))
    expected = np.pi * (r**2 - 0.09) / (10.0 * 2.0)
    assert res.value == pytest.approx(expected, rel=0.03) and not res.satisfied
    # a moving particle does not count
    res = c.evaluate(ctx(field(), pos=pos, radius=np.array([r]), resting=np.array([False])))
    assert res.value == 0.0


def test_stability_speed_change_and_combination():
    f1, f2 = field(u=2.0), field(u=1.9)
    assert not criteria.get("stability")("0.05 m").evaluate(ctx(f1)).satisfied  # not run yet
    assert criteria.get("stability")("0.05 m").evaluate(ctx(f1, stability_displacement=0.01)).satisfied
    sc = criteria.get("speed_change")("0.2 m/s").evaluate(ctx(f2, previous=f1))
    assert sc.value == pytest.approx(0.1) and sc.satisfied
    ec = EndCriteria.from_config({"mode": "all", "max_cycles": 3, "max_speed": "1 m/s", "speed_change": "0.2 m/s"})
    done, results, gov = ec.evaluate(ctx(f2, previous=f1))
    assert not done and [r.satisfied for r in results] == [False, True]
    ec_any = EndCriteria.from_config({"mode": "any", "max_speed": "1 m/s", "speed_change": "0.2 m/s"})
    assert ec_any.evaluate(ctx(f2, previous=f1))[2] == "speed_change"
    with pytest.raises(InputError, match="unknown end criterion"):
        EndCriteria.from_config({"max_sped": "1 m/s"})
    with pytest.raises(InputError, match="mode"):
        EndCriteria([], mode="most")


def test_breach_discharge_is_depth_times_crossing_velocity_over_the_open_breach():
    # h = 2 m, v = -0.8 m/s (toward the flood side: |Q| counts), 21 cells of 0.5 m between x = -5 and 5
    c = criteria.get("breach_discharge")("1 m^3/s")
    r = c.evaluate(ctx(field(depth=2.0, u=3.0, v=-0.8)))
    assert r.value == pytest.approx(2.0 * 0.8 * 21 * DX) and not r.satisfied
    # the flow along the levee (u) does not cross the section; blocking it shuts the discharge
    ds = field(depth=2.0, u=3.0, v=0.8)
    ds["obstacle"] = (("y", "x"), np.ones(ds.depth.shape, "i1"), {"units": "1"})
    assert c.evaluate(ctx(ds)).value == 0.0 and c.evaluate(ctx(ds)).satisfied


def walled_channel(levee_row):
    """2 m of water at 0.8 m/s across the levee, walls beside the opening (x = ±5 m) for y in [-2, 2] m; the
    velocity on the levee line (y = 0) times ``levee_row(x)``."""
    ds = field(depth=2.0, u=0.0, v=0.8)
    x, y = ds.x.values, ds.y.values
    wall = (np.abs(y)[:, None] <= 2.0) & (np.abs(x)[None, :] > 5.0)
    ds["obstacle"] = (("y", "x"), wall.astype("i1"), {"units": "1"})
    v = ds["v"].values.copy()
    v[int(np.argmin(np.abs(y)))] *= levee_row(x)
    ds["v"] = (("y", "x"), v, ds["v"].attrs)
    return ds


def test_breach_discharge_is_the_channel_flux_not_a_row_through_the_pile():
    """Walls beside the opening (x = ±5 m) for y in [-2, 2] m carry 2 m × 0.8 m/s × 10.5 m = 16.8 m³/s
    through every row (continuity); on the levee line a pile's raised bed makes the cell-centre momentum
    1.6 times the flux in 5 cells (what issue 16's nested closure showed: 53.3 on the pile row against
    32.6–36.0 m³/s on the others). The breach discharge is the channel's flux, not that row's."""
    ds = walled_channel(levee_row=lambda x: np.where((x >= -1.0) & (x <= 1.0), 1.6, 1.0))
    wall = ds["obstacle"].values
    c = criteria.get("breach_discharge")("1 m^3/s")
    assert c.evaluate(ctx(ds)).value == pytest.approx(2.0 * 0.8 * 21 * DX)
    # without walls beside the opening the section is the levee line's row alone
    ds["obstacle"] = (("y", "x"), np.zeros_like(wall, "i1"), {"units": "1"})
    assert c.evaluate(ctx(ds)).value == pytest.approx(2.0 * 0.8 * DX * (21 + 0.6 * 5))


@pytest.mark.parametrize("levee_row_factor", [0.97, 1.0, 1.03])
def test_seepage_and_overflow_are_in_the_breach_discharge_section(levee_row_factor):
    """A porous pile the water passes through only: in the levee row (where the seepage is split per cell)
    all of the row's discharge is seepage, so nothing flows over the crest — whatever the channel's other
    rows read (a few % apart at the default scene, where the overflow limit is 0.5 of ~25 m³/s). The
    seepage is carried into the breach discharge's section, so breach discharge - seepage = overflow."""
    from breachflow.cycle.criteria import row_discharge, section_discharge, seepage_in_section

    ds = walled_channel(levee_row=lambda x: levee_row_factor)
    q_row = 2.0 * 0.8 * levee_row_factor * 21 * DX
    q = 2.0 * 0.8 * 21 * DX  # the channel's flux (every other row)
    assert row_discharge(ds, (-5.0, 5.0), 0.0) == pytest.approx(q_row)
    assert section_discharge(ds, (-5.0, 5.0), 0.0) == pytest.approx(q)
    c = criteria.get("overflow_discharge")("0.5 m^3/s")
    for share in (1.0, 0.5, 0.0):
        seep = seepage_in_section(ds, (-5.0, 5.0), 0.0, share * q_row)
        assert seep == pytest.approx(share * q) if share else seep == 0.0
        assert c.evaluate(ctx(ds, seepage_discharge=seep)).value == pytest.approx((1.0 - share) * q, abs=1e-9)
