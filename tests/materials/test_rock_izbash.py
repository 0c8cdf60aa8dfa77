"""Calibration of the rock material against Izbash: a single angular rock (the volume-equivalent sphere with
the rock's shape drag, friction and rolling resistance) in a pocket of a bed of the same units starts moving
at a depth-averaged velocity (uniform profile) between Izbash's exposed and embedded coefficients,
0.86 sqrt(2 g Delta D_n) <= u_c <= 1.2 sqrt(2 g Delta D_n) (Izbash & Khaldre 1970; CIRIA Rock Manual 2007
§5.2.1.2, with D = D_n, the nominal diameter). The rock's C_D is Ganser's (not fitted); its rolling
resistance was chosen so that the band holds for every flow direction over the pocket."""
import math

import pytest

from breachflow.dem import Material
from breachflow.fluid.drag import DRAG_LAWS
from breachflow.studies.stability import stone_moves
from breachflow.materials import get_material

G = 9.80665
EXPOSED, EMBEDDED = 0.86, 1.20


def _moves(rock, dn, coefficient, angle_deg):
    ds = (6 / math.pi) ** (1 / 3) * dn  # the DEM sphere of the unit's volume
    mat = Material(density=rock.density, kn=2.0e7 * (ds / 2.0) ** 2, friction=rock.friction,
                   rolling_friction=rock.rolling_friction)
    delta = (rock.density - 1000.0) / 1000.0
    u = coefficient * math.sqrt(2 * G * delta * dn)
    a = math.radians(angle_deg)
    return stone_moves(u, ds, 10.0, velocity_profile="uniform", material=mat, density=rock.density,
                       drag_law=DRAG_LAWS.create("constant", value=rock.drag_coefficient),
                       direction=(math.cos(a), math.sin(a)))


@pytest.mark.parametrize("dn", [0.5, 1.0, 2.0])
@pytest.mark.parametrize("angle", [0.0, 30.0, 90.0])
def test_single_rock_starts_moving_within_izbash_band(dn, angle):
    """At rest at Izbash's exposed speed, moved at the embedded speed: u_c is inside the band. Flow directions
    0°, 30° (over the saddle between two pocket units, the easiest way out) and 90° are the offsets."""
    rock = get_material("HMA_1000_3000")
    assert not _moves(rock, dn, EXPOSED, angle), "moves below Izbash's exposed-stone speed"
    assert _moves(rock, dn, EMBEDDED, angle), "still at rest at Izbash's embedded-stone speed"


@pytest.mark.parametrize("dn", [0.5, 2.0])
def test_smooth_sphere_parameters_move_too_early_for_rock(dn):
    """The check can fail: the rock's shape drag with the sphere's rolling resistance (0.3, the closure run's
    default) moves the unit below Izbash's exposed-stone speed."""
    rock = get_material("HMA_1000_3000", rolling_friction=0.3)
    assert _moves(rock, dn, EXPOSED, 30.0)
