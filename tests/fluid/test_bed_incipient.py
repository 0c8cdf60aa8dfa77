"""The rough bed in the terrain contact (breachflow.fluid.bed, dem.pocket) and incipient motion in the DEM
(breachflow.studies.incipient) against published data: the pocket's threshold on an incline equals the pivot
angle of Wiberg & Smith (1987); Shields' critical parameter of coarse grains on a bed of the same grains in
0.03-0.06 (Shields 1936; Meyer-Peter & Mueller 1948: 0.047); Izbash's coefficient of rock (C_D = 1, no drag
crisis) in his band 0.86-1.20 for the relative depths at which it is applied to the depth-averaged velocity."""
import math

import numpy as np
import pytest

from breachflow.dem import DemSimulation, HeightField, Material
from breachflow.studies import incipient as I
from breachflow.fluid import nearbed as NB
from breachflow.fluid.bed import BedRoughness, pivot_angle
from breachflow.fluid.drag import ConstantDrag

G = 9.80665


def test_pivot_angle_of_wiberg_and_smith():
    # cos(phi0) = (D/d - 0.02) / (D/d + 1): 60.7 deg for equal grains (Wiberg & Smith 1987)
    assert pivot_angle(1.0, 1.0) == pytest.approx(math.degrees(math.acos(0.49)), abs=1e-9)
    assert pivot_angle(1.0, 1.0) == pytest.approx(60.7, abs=0.05)
    r = np.array([0.5, 1.0, 2.0, 4.0, 16.0, 1e4])
    ang = pivot_angle(r, 1.0)
    assert np.all(np.diff(ang) < 0) and ang[-1] < 1.0  # a boulder on sand rests on a near plane


def incline_moves(alpha_deg, D, d_bed, *, roughness=True, offset=0.0, rolling_friction=0.3, friction=0.6):
    """A sphere released at rest on a plane terrain inclined at alpha (down +x): does it move D/4 in 3 sqrt(D/g)?"""
    x = np.linspace(-4 * D, 4 * D, 9)
    X, _ = np.meshgrid(x, x)
    bed = -math.tan(math.radians(alpha_deg)) * X
    mat = Material(density=2650.0, kn=2e7 * (D / 2) ** 2, friction=friction, rolling_friction=rolling_friction)
    mat = mat.with_restitution(0.3, 2650.0 * math.pi / 6 * D ** 3)
    rough = BedRoughness("natural", d_bed) if roughness else None
    sim = DemSimulation(boundaries=[HeightField(x, x, bed, mat, roughness=rough)], sleeping=False)
    n = np.array([math.sin(math.radians(alpha_deg)), 0.0, math.cos(math.radians(alpha_deg))])
    p0 = np.array([offset, 0.3 * D, -math.tan(math.radians(alpha_deg)) * offset]) + 0.5 * D * n
    k = sim.add_particles(p0[None, :], 0.5 * D, mat)[0]
    T = 3.0 * math.sqrt(D / G)
    for _ in range(30):
        sim.step(max(1, int(T / sim.dt / 30)))
        if np.linalg.norm(sim.state.pos[k] - p0) > 0.25 * D:
            return True
    return False


@pytest.mark.parametrize("ratio", [1.0, 2.0, 6.0])
@pytest.mark.parametrize("offset", [0.0, 0.37])
def test_a_grain_leaves_its_pocket_at_the_pivot_angle(ratio, offset):
    D = 1.0
    phi0 = float(pivot_angle(ratio, 1.0))
    assert not incline_moves(phi0 - 3.0, D, D / ratio, offset=offset)
    assert incline_moves(phi0 + 3.0, D, D / ratio, offset=offset)


def test_a_smooth_bed_keeps_the_material_resistance():
    # rolling resistance 0.3: rolls above atan(0.3) = 16.7 deg, rests below
    assert incline_moves(25.0, 1.0, 1.0, roughness=False)
    assert not incline_moves(12.0, 1.0, 1.0, roughness=False)
    # a very fine rough bed: the pocket (tan phi0 ~ 0.006) is below the material's; the same trajectory, bit for bit
    x = np.linspace(-4, 4, 9)
    bed = -0.4 * np.meshgrid(x, x)[0]
    mat = Material(density=2650.0, kn=5e6, friction=0.6, rolling_friction=0.3)
    runs = []
    for rough in (None, BedRoughness("smooth"), BedRoughness("natural", 1e-4)):
        sim = DemSimulation(boundaries=[HeightField(x, x, bed, mat, roughness=rough)], sleeping=False)
        sim.add_particles(np.array([[0.0, 0.1, 0.52]]), 0.5, mat)
        sim.step(400)
        runs.append((sim.state.pos.copy(), sim.state.omega.copy()))
    for pos, om in runs[1:]:
        assert np.array_equal(pos, runs[0][0]) and np.array_equal(om, runs[0][1])


def test_bad_beds_are_refused():
    from breachflow.errors import InputError

    for kw in ({"kind": "gravel", "grain_size": 0.1}, {"kind": "natural", "grain_size": 0.0},
               {"kind": "protection", "grain_size": 0.5, "thickness": 0.2}):
        with pytest.raises(InputError):
            BedRoughness(**kw)


# -- Shields ---------------------------------------------------------------------------------------------------
# natural grains: no drag crisis (Schiller-Naumann, C_D 0.44 in the Newton regime); equal grains d_bed = D

@pytest.mark.parametrize("D", [0.02, 0.2, 2.0])
def test_shields_critical_parameter_of_coarse_grains(D):
    rng = np.random.default_rng(int(D * 100))
    off = rng.uniform(-0.5, 0.5, 2) * D
    ang = rng.uniform(0, 2 * math.pi)
    theta = I.critical_shields(D, 10.0 * D, drag_law="schiller_naumann", offset=off,
                               direction=(math.cos(ang), math.sin(ang)))
    assert 0.03 <= theta <= 0.06


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("D", [0.01, 0.05, 0.5, 4.0])
@pytest.mark.parametrize("rel_depth", [5.0, 10.0, 20.0])
def test_shields_sweep_of_sizes_depths_and_seeds(seed, D, rel_depth):
    rng = np.random.default_rng(seed)
    off = rng.uniform(-0.5, 0.5, 2) * D
    ang = rng.uniform(0, 2 * math.pi)
    theta = I.critical_shields(D, rel_depth * D, drag_law="schiller_naumann", offset=off,
                               direction=(math.cos(ang), math.sin(ang)))
    assert 0.03 <= theta <= 0.06


def test_without_the_near_bed_terms_the_sphere_is_too_stable():
    """The calibration needs the terms: drag at the exposed height alone gives theta_c ~ 0.095, twice MPM's."""
    theta = I.critical_shields(0.2, 2.0, drag_law="schiller_naumann", near_bed=NB.parameters(terms=()))
    assert theta > 0.07


# -- Izbash ----------------------------------------------------------------------------------------------------
# angular rock: C_D = 1 without drag crisis (a per-unit drag coefficient), friction 0.6, rolling resistance 0.3,
# on a bed of the same rock; Izbash's coefficient of the depth-averaged velocity at h/D of 3 to 8

@pytest.mark.parametrize("D,rel_depth", [(1.0, 3.0), (4.0, 5.0), (0.5, 8.0)])
def test_izbash_coefficient_of_angular_rock(D, rel_depth):
    c = I.izbash_coefficient(D, rel_depth * D, drag_law=ConstantDrag(1.0))
    assert 0.86 <= c <= 1.20
