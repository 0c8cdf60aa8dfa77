"""Bed shear, Shields threshold, Meyer-Peter–Müller bed load and the Exner update (breachflow.hydro.morphology)
against independent arithmetic and analytic results: the formulas, the bed volume of a closed box (conserved to
round-off), no change below the threshold, a protected patch that holds, and the clear-water equilibrium scour
depth (Laursen 1963; FHWA HEC-18's K_u = 0.025 form)."""
import math

import numpy as np
import pytest

from breachflow.hydro import morphology as M

G = 9.80665


def test_formulas_against_arithmetic():
    tau = M.bed_shear(4.0, 3.0, 4.0, 0.025)
    assert tau == pytest.approx(1000 * G * 0.025 ** 2 * 25.0 / 4.0 ** (1 / 3), rel=1e-14)
    th = M.shields(tau, 0.01)
    assert th == pytest.approx(tau / (1650 * G * 0.01), rel=1e-14)
    q = M.mpm_transport(0.1, 0.01)
    assert q == pytest.approx(8 * 0.053 ** 1.5 * math.sqrt(1.65 * G * 1e-6), rel=1e-12)
    assert M.mpm_transport(0.047, 0.01) == 0.0 and M.mpm_transport(0.02, 0.01) == 0.0
    assert M.bed_shear(0.0, 3.0, 0.0, 0.025) == 0.0


def test_hec18_clear_water_contraction_scour_is_the_equilibrium_depth():
    """HEC-18 clear-water contraction scour (SI): y2 = (0.025 q^2 / D_m^(2/3))^(3/7), D_m = 1.25 D50, from n = 0.041 D_m^(1/6) and
    theta_c = 0.039: the same law as equilibrium_depth with those n and theta_c (to the rounding of 0.025)."""
    for q, d50 in ((10.0, 0.01), (30.0, 0.002), (5.0, 0.05)):
        dm = 1.25 * d50
        hec = (0.025 * q ** 2 / dm ** (2 / 3)) ** (3 / 7)
        ours = M.equilibrium_depth(q, dm, 0.041 * dm ** (1 / 6), theta_c=0.039)
        assert ours == pytest.approx(hec, rel=0.02)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_closed_box_conserves_the_bed_volume(seed):
    rng = np.random.default_rng(seed)
    ny, nx = 20, 30
    bed = rng.normal(0, 0.05, (ny, nx))
    depth = 2.0 + rng.uniform(0, 1, (ny, nx))
    u = rng.normal(2.5, 1.0, (ny, nx))
    v = rng.normal(0.0, 1.0, (ny, nx))
    new, steps, _ = M.scour(bed, depth, u, v, 0.002, 0.03, 60.0, dx=2.0, dy=3.0, open_edges=False)
    assert steps > 5 and np.abs(new - bed).max() > 1e-3
    assert new.sum() == pytest.approx(bed.sum(), abs=1e-11 * bed.size)


def test_no_change_below_the_threshold_and_a_protection_holds():
    ny, nx = 5, 40
    bed = np.zeros((ny, nx))
    depth = np.full((ny, nx), 3.0)
    u = np.full((ny, nx), 1.0)
    v = np.zeros((ny, nx))
    d = 0.05  # theta = 1000 g n^2 1 / 3^(1/3) / (1650 g 0.05) = 0.0053 << 0.047
    new, steps, _ = M.scour(bed, depth, u, v, d, 0.025, 3600.0, dx=1.0, dy=1.0)
    assert steps == 0 and np.array_equal(new, bed)
    # a fast jet over sand with a protected patch of 1 m stones in its middle
    u[:] = 4.0
    dmap = np.full((ny, nx), 0.001)
    dmap[:, 15:25] = 1.0
    new, _, _ = M.scour(bed, depth, u, v, dmap, 0.025, 300.0, dx=1.0, dy=1.0)
    assert (bed - new)[:, 0].min() > 0.05  # the sand at the head scours
    # the protection's own threshold is not exceeded: it never scours; the sand it receives moves on over it
    assert (new[:, 15:25] >= bed[:, 15:25]).all()
    assert (new[:, 15:25] - bed[:, 15:25]).max() < 0.5


def test_clear_water_scour_levels_off_at_the_laursen_depth():
    """A flume of sand fed no sediment: every cell scours towards h_eq = (rho g n^2 q^2 / tau_c)^(3/7) and not
    beyond (the velocity falls as the depth grows)."""
    nx = 30
    h0, U, n, d = 2.0, 2.5, 0.025, 0.004
    bed = np.zeros((1, nx))
    q = h0 * U
    h_eq = float(M.equilibrium_depth(q, d, n))
    assert h_eq > h0 * 1.2
    new, steps, _ = M.scour(bed, np.full((1, nx), h0), np.full((1, nx), U), np.zeros((1, nx)), d, n, 3.0e6, dx=1.0,
                         dy=1.0, max_steps=400000)
    depth = h0 - new[0]
    assert depth.max() <= h_eq * (1 + 1e-6)
    assert depth[0] == pytest.approx(h_eq, rel=0.01)  # the head of the flume: no supply from upstream


def test_equilibrium_scour_per_cell():
    depth = np.array([[2.0, 2.0, 3.0, 0.0]])
    u = np.array([[2.5, 0.2, 4.0, 3.0]])
    v = np.array([[0.0, 0.0, 3.0, 0.0]])
    s = M.equilibrium_scour(depth, u, v, 0.004, 0.025)
    heq = [(1000 * G * 0.025 ** 2 * (h * sp) ** 2 / (0.047 * 1650 * G * 0.004)) ** (3 / 7)
           for h, sp in ((2.0, 2.5), (2.0, 0.2), (3.0, 5.0))]
    assert s[0, 0] == pytest.approx(heq[0] - 2.0, rel=1e-12)
    assert s[0, 1] == 0.0 and heq[1] < 2.0  # below the threshold: no scour
    assert s[0, 2] == pytest.approx(heq[2] - 3.0, rel=1e-12)
    assert s[0, 3] == 0.0  # dry
