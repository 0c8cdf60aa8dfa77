"""Contacts with the terrain at a breach wall (breachflow.dem.wall_contacts.terrain_contacts): a sphere at the
foot of a steep wall, or on its crest, touches what it overlaps and nothing else, on the grid sizes a closure
runs on.

Checks against geometry worked by hand: the nearest point of a plane floor and of a plane wall, and the
distance from a straight ridge; and by the sphere's fate: dropped anywhere near a 75-degree wall of 2 m cells
it comes to rest (the single tangent plane the terrain had before shot it out at 12 m/s, or left it sinking
into the wall until its centre passed the wall's foot)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from breachflow.dem import DemSimulation, HeightField, Material, sphere_mass
from breachflow.dem.wall_contacts import MAX_TERRAIN_CANDIDATES, MAX_TERRAIN_CONTACTS, terrain_contacts

R = 1.035  # a 10-15 t rock as a sphere
KN = 2e8
M = float(sphere_mass(R, 2650.0))
FLOOR, CREST, FOOT = 30.5, 38.0, 30.0  # the breach floor, the levee's crest, the wall between them at x = 30


def wall(cell):
    """A breach wall on a grid of *cell* m: floor up to the cell centre before x = 30, crest from x = 30 on;
    the bilinear terrain rises over the one cell before x = 30 (75 degrees at 2 m cells)."""
    x = np.arange(0.0, 48.01, cell)
    y = np.arange(-12.0, 12.01, cell)
    return x, y, np.where(x[None, :] < FOOT, FLOOR, CREST) * np.ones((y.size, 1))


def contacts(cell, c, v=(0.0, 0.0, 0.0), reach=0.0):
    x, y, z = wall(cell)
    out = np.empty((MAX_TERRAIN_CONTACTS, 4))
    m = terrain_contacts(x[0], y[0], cell, cell, z, c[0], c[1], c[2], R, *v, reach, out,
                         np.empty((MAX_TERRAIN_CANDIDATES, 5)))
    return out[:m]


def test_floor_and_wall_at_the_foot_by_hand():
    """2 m cells: the wall's plane through (28, 30.5) and (30, 38), unit normal (-sin a, 0, cos a) with
    tan a = 3.75. A centre 1 m above the floor, 1 m from that plane: two contacts, the floor first (it keeps
    the histories), overlaps R - 1 each."""
    a = math.atan(3.75)
    n_wall = np.array([-math.sin(a), 0.0, math.cos(a)])
    foot = np.array([28.0, 0.3, FLOOR])
    # the point 1 m above the floor and 1 m off the wall plane: c = foot + s e_x + 1 e_z with (c - foot) . n_wall = 1
    s = (1.0 - n_wall[2]) / n_wall[0]
    c = foot + np.array([s, 0.0, 1.0])
    got = contacts(2.0, c)
    assert got.shape == (2, 4)
    np.testing.assert_allclose(got[0], [0.0, 0.0, 1.0, R - 1.0], atol=1e-12)
    np.testing.assert_allclose(got[1], [*n_wall, R - 1.0], atol=1e-12)


def test_one_contact_on_a_plane_floor_whatever_patches_the_footprint_covers():
    """A sphere on the floor over the corner of four patches: one contact, straight up, overlap by hand."""
    for cell in (0.5, 1.0, 2.0, 4.0):
        got = contacts(cell, (10.0, 0.0, FLOOR + R - 0.01))
        assert got.shape == (1, 4)
        np.testing.assert_allclose(got[0], [0.0, 0.0, 1.0, 0.01], atol=1e-12)


def test_the_crest_edge_is_a_distance_from_the_ridge_not_the_wall_plane_extended():
    """Beyond the wall's top (x > 30) over the crest, a centre 1.1 m above the crest is apart (the wall's plane
    extended would overlap it by 1.18 m, the former contact's phantom); one just over the ridge line touches
    it at the distance from the ridge (x = 30, z = 38)."""
    assert contacts(2.0, (30.5, 0.3, CREST + 1.1)).shape[0] == 0
    c = np.array([29.9, 0.3, CREST + 0.9])
    d = math.hypot(c[0] - FOOT, c[2] - CREST)
    got = contacts(2.0, c)
    assert got.shape == (1, 4)
    np.testing.assert_allclose(got[0], [(c[0] - FOOT) / d, 0.0, (c[2] - CREST) / d, R - d], atol=1e-12)


def test_a_contact_that_begins_within_the_force_interval_counts():
    """Apart by 1 mm and closing at 2 m/s: within an interval of 1 ms it touches (the step-averaged law)."""
    c = (10.0, 0.0, FLOOR + R + 1e-3)
    assert contacts(2.0, c).shape[0] == 0
    assert contacts(2.0, c, v=(0.0, 0.0, -2.0), reach=1e-3).shape[0] == 1


def last_speed(sim):
    """The sphere's highest speed (m/s) over the next 400 steps, sampled every 20: at rest, not jittering."""
    speeds = []
    for _ in range(20):
        sim.step(20)
        speeds.append(float(np.linalg.norm(sim.state.vel[0])))
    return max(speeds)


def rock():
    e = 0.3
    zeta = -math.log(e) / math.sqrt(math.pi ** 2 + math.log(e) ** 2)
    return Material(kn=KN, friction=0.6, rolling_friction=0.3, c_cn=2 * zeta * math.sqrt(KN * M),
                    c_cs=2 * zeta * math.sqrt(KN * M / 3.5))


@pytest.mark.parametrize("cell", [4.0, 2.0, 1.0])
@pytest.mark.parametrize("x0", [27.0, 28.8, 29.5, 30.5])
def test_a_rock_dropped_at_a_breach_wall_comes_to_rest(cell, x0):
    """Dropped 0.3 m above the highest ground under it, at the wall's foot, on its face or on its crest: it
    never moves faster than its fall and the roll down the wall allow (sqrt(2 g 8 m) = 12.5 m/s), and rests
    within 20 s, on the floor or the crest, and not in the wall."""
    x, y, z = wall(cell)
    mat = rock()
    ground = np.interp(np.linspace(x0 - R, x0 + R, 41), x, z[0]).max()
    sim = DemSimulation(boundaries=[HeightField(x, y, z, mat)], sleeping=False)
    sim.add_particles([[x0, 0.3, ground + R + 0.3]], R, mat)
    fastest = 0.0
    for _ in range(100):
        sim.run(0.2)
        fastest = max(fastest, float(np.linalg.norm(sim.state.vel[0])))
    assert fastest < math.sqrt(2 * 9.81 * 8.0)
    assert last_speed(sim) < 1e-6
    px, _, pz = sim.state.pos[0]
    on_floor = abs(pz - (FLOOR + R)) < 1e-2
    on_crest = abs(pz - (CREST + R)) < 1e-2 and px >= FOOT
    assert on_floor or on_crest
    # not in the wall: its centre at least R (less the elastic overlap) from every point of the terrain
    xs = np.linspace(px - 2 * R, px + 2 * R, 2001)
    zs = np.interp(xs, x, z[0])
    assert np.hypot(xs - px, zs - pz).min() > R - 1e-3


@pytest.mark.parametrize("cell", [2.0, 1.0])
def test_a_rock_pushed_against_the_wall_rests_against_it(cell):
    """Pushed towards the wall with its own weight (more than the floor's friction holds), a rock on the
    floor rolls to the wall's foot and rests there, floor and wall carrying it: its overlap with the wall is
    elastic (the push over the wall's stiffness, not the metre the former contact let it sink in)."""
    x, y, z = wall(cell)
    mat = rock()

    class Push:
        def added_mass(self, state):
            return None

        def accumulate(self, state, pos, vel, omega, t, force, torque):
            force[:, 0] += M * 9.81

    sim = DemSimulation(boundaries=[HeightField(x, y, z, mat)], models=[Push()], sleeping=False)
    sim.add_particles([[24.0, 0.3, FLOOR + R]], R, mat)
    sim.run(20.0)
    assert last_speed(sim) < 1e-6
    px, _, pz = sim.state.pos[0]
    xs = np.linspace(px - 2 * R, px + 2 * R, 4001)
    zs = np.interp(xs, x, z[0])
    gap = np.hypot(xs - px, zs - pz).min() - R
    # the wall's normal force is at most the push over sin(a) plus the weight: overlap below (2 M g) / kn
    assert -2 * M * 9.81 / KN < gap < 0.0
