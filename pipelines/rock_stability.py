"""Critical velocity of a single unit of a closure material on a bed of the same units, against Izbash.

``python pipelines/rock_stability.py [MATERIAL]`` (default ``HMA_1000_3000``) bisects, for nominal diameters
D_n = 0.5, 1, 2 m and flow directions 0°, 30°, 60°, 90°, 180° over the bed pocket, the depth-averaged velocity
(uniform profile, 10 m of water) at which the unit — its volume-equivalent sphere with the material's drag
coefficient, friction and rolling resistance (:mod:`breachflow.materials`) — starts to move
(:func:`breachflow.studies.stability.stone_moves`), and prints ``u_c / sqrt(2 g Delta D_n)`` next to Izbash's
exposed (0.86) and embedded (1.2) coefficients.
"""
from __future__ import annotations

import math
import sys


def critical_coefficient(material, dn, angle_deg, depth=10.0, tol=0.005):
    from breachflow.dem import Material
    from breachflow.fluid.drag import DRAG_LAWS
    from breachflow.studies.stability import stone_moves

    g = 9.80665
    ds = (6 / math.pi) ** (1 / 3) * dn
    mat = Material(density=material.density, kn=2.0e7 * (ds / 2) ** 2, friction=material.friction,
                   rolling_friction=material.rolling_friction)
    u0 = math.sqrt(2 * g * (material.density - 1000.0) / 1000.0 * dn)
    a = math.radians(angle_deg)
    law = DRAG_LAWS.create("constant", value=material.drag_coefficient)
    lo, hi = 0.3, 2.0
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        if stone_moves(mid * u0, ds, depth, velocity_profile="uniform", material=mat, density=material.density,
                       drag_law=law, direction=(math.cos(a), math.sin(a))):
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi)


def main(name="HMA_1000_3000"):
    from breachflow.materials import get_material

    m = get_material(name)
    angles = (0.0, 30.0, 60.0, 90.0, 180.0)
    print(f"{name}: C_D {m.drag_coefficient:.3f}, friction {m.friction:g}, rolling resistance {m.rolling_friction:g}")
    print("D_n (m) | " + " | ".join(f"{a:g}°" for a in angles))
    allc = []
    for dn in (0.5, 1.0, 2.0):
        row = [critical_coefficient(m, dn, a) for a in angles]
        allc += row
        print(f"{dn:g} | " + " | ".join(f"{c:.3f}" for c in row))
    print(f"band {min(allc):.3f}-{max(allc):.3f} (Izbash exposed 0.86, embedded 1.2)")


if __name__ == "__main__":
    main(*sys.argv[1:2])
