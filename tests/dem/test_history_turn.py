"""The contact history turned into a new tangent plane (``contact_law.history_in_plane``): its normal part
removed and its length kept, for turn angles from 1e-9 rad to 1.2 rad on both sides of the switch between
the series for ``(1 - x)^-1/2`` and the quotient of square roots (``x = 2^-14``), against the exact
rotation computed in extended precision (numpy longdouble) from the same double inputs."""
from __future__ import annotations

import numpy as np
import pytest

from breachflow.dem.contact_law import TURN_SERIES, history_in_plane

ANGLES = np.concatenate([np.geomspace(1e-9, 1.2, 60), np.sqrt(TURN_SERIES) * np.array([0.999, 1.0, 1.001])])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_turned_history_keeps_its_length_and_lies_in_the_plane(seed):
    rng = np.random.default_rng(seed)
    worst_len = worst_dir = 0.0
    for ang in ANGLES:
        for scale in (1e-7, 1e-3, 10.0):
            n = rng.normal(size=3)
            n /= np.linalg.norm(n)
            t = rng.normal(size=3)
            t -= t.dot(n) * n
            t /= np.linalg.norm(t)
            h = scale * (np.cos(ang) * t + np.sin(ang) * n)  # stored in a plane turned by `ang` from n's
            hist = h.reshape(1, 3).copy()
            hx, hy, hz, s0 = history_in_plane(hist, 0, n[0], n[1], n[2])
            got = np.array([hx, hy, hz], np.longdouble)
            hl = hist[0].astype(np.longdouble)
            nl = n.astype(np.longdouble)
            perp = hl - hl.dot(nl) * nl
            want = perp * np.sqrt(hl.dot(hl) / perp.dot(perp))
            assert s0 == h.dot(h) or abs(s0 / h.dot(h) - 1) < 1e-15
            err = float(np.linalg.norm(got - want) / np.linalg.norm(want))
            worst_dir = max(worst_dir, err)
            worst_len = max(worst_len, abs(float(np.linalg.norm(got) / np.sqrt(hl.dot(hl))) - 1.0))
            # the normal residual: a few roundings of |h| in the projection, then scaled by |h| / |h_t|
            # (1 / cos of the turn, up to 2.8 at 1.2 rad); 4 roundings of the scaled length. (A fixed
            # 1e-15 |h| ignored the scaling: 1.02e-15 |h| = 1.7 roundings x 2.76 at 1.2 rad, seed 2, with the
            # FMA rounding of AVX2 CPUs.)
            stretch = float(np.sqrt(hl.dot(hl) / perp.dot(perp)))
            assert abs(float(got.dot(nl))) <= 4 * np.finfo(float).eps * scale * stretch
    assert worst_len < 4e-16, worst_len  # a few roundings: the length is kept
    assert worst_dir < 6e-16, worst_dir


def test_zero_history_stays_zero():
    hist = np.zeros((1, 3))
    assert history_in_plane(hist, 0, 0.0, 0.6, 0.8) == (0.0, 0.0, 0.0, 0.0)
