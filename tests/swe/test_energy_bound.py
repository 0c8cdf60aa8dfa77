"""The energy bound of steady shallow-water flow: no cell is faster than a fall from the upstream head.

In steady flow the total head ``E = z + h + |u|^2 / 2g`` only decreases along the flow (friction, hydraulic
jumps), so ``|u| <= sqrt(2 g (H - z))`` with ``H`` the head supplied at the inlet — an analytic bound that
needs no reference solution. Scenes: flow from a reservoir (level 3 m) over a raised, bumpy plateau — beds
like those a ``raised_bed`` remap of a rock pile makes, with pits lower than their neighbours next to banks
above the water — swept over seeds, plateau slopes and grid orientations; and 1-D plateaus with pits of
1-2 cells at several depths and offsets.

Before the fix in :func:`breachflow.swe.fluxes.slopes`, the second-order reconstruction took a dry
bank's bed as the surface of the pit next to it; the spurious surface slope drove the pit's water against
faces that hydrostatic reconstruction leaves without reaction, until friction balanced it: heads 0.4-4.8 m
above the reservoir's (seed 1, slopes 0-0.2; 10.4 m/s in 0.95 m of water), speeds up to 4.7 m/s above the
speed bound. (The 1-D pits never broke the bound, before or after.)
"""
import numpy as np
import pytest

from breachflow.swe import SWEOptions, SWESimulation
from breachflow.swe.domain import BoundaryCondition as BC, uniform_grid

G = 9.81
H = 3.0  # reservoir level (m)


def speed_excess(sim, dom, h_min=1e-6, factor=1.0, inflow=(slice(None), 0)):
    """Largest ``|u| - factor sqrt(2 g (H_in - z))`` over the wet cells (m/s) and that cell; ``H_in`` is the
    largest head on the inflow cells *inflow* (the west column) — the head the reservoir supplies."""
    h = sim.depth
    qx, qy = sim.discharge
    z = dom.bed
    wet = h > h_min
    sp = np.where(wet, np.hypot(qx, qy) / np.where(wet, h, 1.0), 0.0)
    head_in = max(H, float((z + h + sp ** 2 / (2 * G))[inflow].max()))
    ex = np.where(wet, sp - factor * np.sqrt(2 * G * np.maximum(head_in - z, 0.0)), -np.inf)
    k = np.unravel_index(np.argmax(ex), ex.shape)
    return float(ex[k]), k, float(sp[k]), float(h[k])


def head_excess(sim, dom, h_min=1e-2, inflow=(slice(None), 0)):
    """Largest ``z + h + |u|^2/2g - H_in`` (m) over the cells deeper than *h_min* — the full energy bound of
    steady flow (stricter than the speed bound where the water is deep)."""
    h = sim.depth
    qx, qy = sim.discharge
    z = dom.bed
    wet = h > 1e-6
    sp = np.where(wet, np.hypot(qx, qy) / np.where(wet, h, 1.0), 0.0)
    head = z + h + sp ** 2 / (2 * G)
    head_in = max(H, float(head[inflow].max()))
    ex = np.where(h > h_min, head - head_in, -np.inf)
    k = np.unravel_index(np.argmax(ex), ex.shape)
    return float(ex[k]), k, float(sp[k]), float(h[k])


def bumpy_plateau(seed, slope, lo=-0.8, hi=1.0, dx=1.0, angle_deg=0.0):
    """Reservoir (x < 10 m), then a 15 m plateau at 2.4 m falling at *slope*, bed roughened by uniform
    noise in ``[lo, hi]`` (pits down to 1.6 m, banks up to 3.4 m above the 3 m level), then a free outfall.
    *angle_deg*: the plateau's fall line is turned by this angle against the grid."""
    rng = np.random.default_rng(seed)
    L, W = 40.0, 12.0
    nx, ny = int(L / dx), int(W / dx)
    x = (np.arange(nx) + 0.5) * dx
    y = (np.arange(ny) + 0.5) * dx
    X, Y = np.meshgrid(x, y)
    a = np.radians(angle_deg)
    s = 10.0 + (X - 10.0) * np.cos(a) + (Y - W / 2) * np.sin(a)  # distance along the fall line
    plate = (X > 10.0) & (X < 25.0)
    bed = np.where(plate, 2.4 - slope * (s - 10.0) + rng.uniform(lo, hi, X.shape), 0.0)
    return uniform_grid(0, L, 0, W, dx, bed=bed, initial_surface=np.where(X < 10.0, H, bed), manning=0.025,
                        boundaries={"west": [BC.water_level(H)], "east": [BC.outflow()],
                                    "north": [BC.wall()], "south": [BC.wall()]})


#: cell sizes of the pile scenes: the 0.5 m cells (about 6x the 1 m cost) in the slow suite (``tasks.py test --slow``)
DX = [1.0, pytest.param(0.5, marks=pytest.mark.slow)]

CASES = [(seed, slope, 0.0) for seed in (0, 1, 2, 3) for slope in (0.0, 0.1, 0.2)] + \
        [(seed, 0.1, angle) for seed in (0, 1) for angle in (20.0, 45.0)]


@pytest.mark.parametrize("seed, slope, angle", CASES)
def test_no_cell_outruns_a_fall_from_the_upstream_head_over_a_bumpy_plateau(seed, slope, angle):
    dom = bumpy_plateau(seed, slope, angle_deg=angle)
    sim = SWESimulation(dom)  # the defaults: second order, minmod, HLLC
    sim.run_to_steady(tolerance=1e-5, t_max=300.0)
    ex, cell, sp, h = speed_excess(sim, dom)
    # a tenth of a m/s for the discretisation of a bound that holds exactly only for the PDE
    assert ex < 0.1, (cell, sp, h, ex)
    ex, cell, sp, h = head_excess(sim, dom)
    assert ex < 0.1, (cell, sp, h, ex)  # 0.1 m of head; the pits of the old scheme were 0.4-4.8 m above
    assert np.hypot(*sim.discharge).max() > 0.2  # water really flows over the plateau


@pytest.mark.parametrize("pit_depth, n_pit, offset", [(d, n, o) for d in (0.3, 1.0) for n in (1, 2) for o in (0, 3)])
def test_one_dimensional_plateau_with_a_pit(pit_depth, n_pit, offset):
    """A 10 m plateau 2.4 m high (0.6 m below the reservoir level) with a pit of *n_pit* cells, *pit_depth*
    deep, *offset* cells past its third metre; 0.5 m cells, free outfall."""
    dx, x0 = 0.5, 15.0

    def bed(X, Y):
        z = np.where((X > x0) & (X < x0 + 10), 2.4, 0.0)
        pit = (X > x0 + 3 + offset * dx) & (X < x0 + 3 + (offset + n_pit) * dx)
        return np.where(pit, 2.4 - pit_depth, z)

    dom = uniform_grid(0, 40.0, 0, dx, dx, dy=dx, bed=bed,
                       initial_surface=lambda X, Y: np.where(X < x0, H, bed(X, Y)),
                       boundaries={"west": [BC.water_level(H)], "east": [BC.outflow()]})
    sim = SWESimulation(dom)
    sim.run_to_steady(tolerance=1e-6, t_max=300.0)
    ex, cell, sp, h = speed_excess(sim, dom)
    assert ex < 0.1, (cell, sp, h, ex)
    ex, cell, sp, h = head_excess(sim, dom)
    assert ex < 0.1, (cell, sp, h, ex)
    # water flows over the plateau, below the broad-crested weir's ideal q = sqrt(g) (2/3 (H - 2.4))^1.5
    q = sim.discharge[0][0, int(35 / dx)]
    assert 0.2 < q <= np.sqrt(G) * (2 / 3 * (H - 2.4)) ** 1.5


def pile_column(z_up, z_c, drop, dx, row, axis):
    """Reservoir (x < 10 m), a 2 m plateau at *z_up* across the channel (a broad-crested weir), then one
    cell-wide column of pile at *z_c* (a crest between two open-floor slots at 0 m) continued by one cell
    *drop* lower that stays dry, open floor down to a free outfall; *row* cells off the channel's axis;
    *axis* 1 turns the scene by 90° (flow along y). The raised-bed pile column of the nested closure (seed 3,
    cycle 4): 0.29 m of water at 4.6 m/s on a 1.87 m column below a 2.45 m step, beside 1.9 m deep slots."""
    L, W, x0 = 30.0, 7.0, 10.0
    n, m = int(round(L / dx)), int(round(W / dx))
    bed = np.zeros((m, n))
    a = int(round(x0 / dx))
    b = a + int(round(2.0 / dx))
    jc = m // 2 + row
    bed[:, a:b] = z_up
    bed[jc, b] = z_c
    bed[jc, b + 1] = z_c - drop
    surf = np.where(((np.arange(n) + 0.5) * dx)[None, :] < x0, H, bed)
    if axis == 1:
        return uniform_grid(0, W, 0, L, dx, bed=bed.T.copy(), initial_surface=surf.T.copy(), manning=0.025,
                            boundaries={"south": [BC.water_level(H)], "north": [BC.outflow()],
                                        "east": [BC.wall()], "west": [BC.wall()]})
    return uniform_grid(0, L, 0, W, dx, bed=bed, initial_surface=surf, manning=0.025,
                        boundaries={"west": [BC.water_level(H)], "east": [BC.outflow()],
                                    "north": [BC.wall()], "south": [BC.wall()]})


@pytest.mark.parametrize("axis", [0, 1])
@pytest.mark.parametrize("dx", DX)
@pytest.mark.parametrize("row", [0, 2])
@pytest.mark.parametrize("z_up, z_c, drop", [(2.45, 1.87, 0.2), (2.6, 1.87, 0.5), (2.45, 1.5, 0.5)])
def test_a_pile_column_spilling_onto_a_dry_cell_gains_no_head(z_up, z_c, drop, dx, row, axis):
    """A one-cell pile column fed over a 0.58-1.1 m step and spilling onto a lower dry cell: no cell
    deeper than 1 cm carries more head than the reservoir's (+0.1 m for the discretisation). Before the
    dry-neighbour fade of :func:`breachflow.swe.fluxes.slopes` the limiter took the dry cell's bed
    as the column's surface slope: 4.6-5.7 m/s on the column, heads 0.13-0.69 m above the reservoir's (16
    of these 24 cases; the (2.45, 1.5, 0.5) column held the bound before too)."""
    dom = pile_column(z_up, z_c, drop, dx, row, axis)
    sim = SWESimulation(dom)  # the defaults: second order, minmod, HLLC
    sim.run_to_steady(tolerance=1e-5, t_max=300.0)
    inflow = (0, slice(None)) if axis == 1 else (slice(None), 0)
    ex, cell, sp, h = head_excess(sim, dom, inflow=inflow)
    assert ex < 0.1, (cell, sp, h, ex)
    ex, cell, sp, h = speed_excess(sim, dom, inflow=inflow)
    assert ex < 0.1, (cell, sp, h, ex)
    q = np.hypot(*sim.discharge)
    assert q[dom.bed == z_c].max() > 0.05  # water really runs along the column


def foot_of_fall(z_d, open_cols, dx, axis):
    """Flow along +y from a reservoir (y < 8 m, level 3 m) through a wall across the channel (3.3 m) with a
    slot (0 m) and a crest at 2.93 m carrying a thin film; below the crest one pile cell at 1.67 m, fed from
    the side (cells at 1.75 and 1.98 m behind the slot) and spilling onto a lower, shallow cell at *z_d*;
    then open floor down to a free outfall. *open_cols*: columns of the wall open to the floor (more water
    around the pile column); *axis* 1 turns the scene by 90° (flow along x). The layout of the HEC-RAS
    nested closure at seed 12, cycle 3 (x = 2.5, y = 0.5 m), where 0.67 m of water ran at 7.65 m/s."""
    width, n_res, n_out, ic = 7, 8, 10, 3
    bed = np.zeros((n_res + 3 + n_out, width))
    r = n_res
    bed[r:r + 2, :] = 3.3
    bed[r, ic - 1:ic + 1] = (0.0, 2.93)                     # slot, crest with its film
    bed[r + 1, ic - 2:ic + 2] = (1.98, 1.75, 1.67, 2.92)     # the feed beside the pile cell, the pile cell, a dry block
    bed[r + 2, ic] = z_d
    for c in open_cols:
        bed[r:r + 2, c] = 0.0
    k = int(round(1.0 / dx))
    bed = np.kron(bed, np.ones((k, k)))
    surf = np.where(((np.arange(bed.shape[0]) + 0.5) * dx)[:, None] < n_res, H, bed)
    if axis == 1:
        return uniform_grid(0, bed.shape[0] * dx, 0, width, dx, bed=bed.T.copy(), initial_surface=surf.T.copy(),
                            manning=0.025, boundaries={"west": [BC.water_level(H)], "east": [BC.outflow()],
                                                       "north": [BC.wall()], "south": [BC.wall()]})
    return uniform_grid(0, width, 0, bed.shape[0] * dx, dx, bed=bed, initial_surface=surf, manning=0.025,
                        boundaries={"south": [BC.water_level(H)], "north": [BC.outflow()],
                                    "east": [BC.wall()], "west": [BC.wall()]})


@pytest.mark.parametrize("axis", [0, 1])
@pytest.mark.parametrize("dx", DX)
@pytest.mark.parametrize("open_cols", [(), (5, 6), (0, 6)])
@pytest.mark.parametrize("z_d", [1.59, 1.2])
def test_a_pile_cell_at_the_foot_of_a_fall_gains_no_head(z_d, open_cols, dx, axis):
    """A pile cell below a crest carrying a thin film (its bed above the cell's surface: a fall), spilling
    onto a lower, shallow cell: no cell deeper than 1 cm carries more head than the reservoir's (+0.1 m).
    Before the bound on the implied bed slope in :func:`breachflow.swe.fluxes.slopes`, the limiter
    took the film's surface 1.3 m above the cell's bed and the lower cell's surface as one surface slope
    of the pile cell (its bed is flat): 0.30-2.76 m of head above the reservoir's (all 24 cases; 20 of them
    with only the dry-neighbour fade)."""
    dom = foot_of_fall(z_d, open_cols, dx, axis)
    sim = SWESimulation(dom)  # the defaults: second order, minmod, HLLC
    sim.run_to_steady(tolerance=1e-5, t_max=300.0)
    inflow = (slice(None), 0) if axis == 1 else (0, slice(None))
    ex, cell, sp, h = head_excess(sim, dom, inflow=inflow)
    assert ex < 0.1, (cell, sp, h, ex)
    ex, cell, sp, h = speed_excess(sim, dom, inflow=inflow)
    assert ex < 0.1, (cell, sp, h, ex)
    q = np.hypot(*sim.discharge)
    pile = np.isclose(dom.bed, 1.67)
    assert q[pile].max() > 0.05  # water really runs through the pile cell
