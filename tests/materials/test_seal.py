"""Seal layers on a rock dam: filter rules, 1-D Forchheimer flow through layers in series, tonnage."""
import math

import pytest
from scipy.optimize import brentq

from breachflow.errors import InputError
from breachflow.swe.porous import forchheimer_coefficients
from breachflow.materials import get_material
from breachflow.materials.seal import (DEFAULT_SEAL_GRADINGS, Grading, SealDesign, check_filter, required_thickness,
                                       sealed_leakage, series_unit_discharge)

SAND, GRAVEL, QUARRY = (DEFAULT_SEAL_GRADINGS[k] for k in ("sand", "gravel", "quarry_run"))
ROCK = Grading.from_rock(get_material("HMA_1000_3000"))


def test_sand_on_rock_washes_out_and_is_refused_with_names_and_ratio():
    with pytest.raises(InputError) as exc:
        check_filter([SAND, ROCK])
    msg = str(exc.value)
    assert "sand would wash out through HMA_1000_3000" in msg
    # the ratio in the message is D15_rock / D85_sand, computed here by hand
    assert f"{ROCK.d15 / SAND.d85:.3g}" in msg
    with pytest.raises(InputError, match="wash out"):
        SealDesign(SAND, 1.0, ROCK)


def test_graded_filter_sequence_passes_terzaghi():
    rows = check_filter([SAND, GRAVEL, QUARRY, ROCK])
    assert [r["base"] for r in rows] == ["sand", "gravel", "quarry_run"]
    for r, (b, f) in zip(rows, [(SAND, GRAVEL), (GRAVEL, QUARRY), (QUARRY, ROCK)]):
        assert r["retention"] == pytest.approx(f.d15 / b.d85) and r["retention"] <= 5
        assert r["permeability"] == pytest.approx(f.d15 / b.d15) and r["permeability"] >= 5


def test_a_filter_too_close_to_its_base_does_not_drain():
    fine = Grading("fine", 1e-3, 2e-3, 4e-3)
    near = Grading("near", 2e-3, 4e-3, 8e-3)
    with pytest.raises(InputError, match=r"near does not drain fine: D15_near/D15_fine = 2 < 5"):
        check_filter([fine, near])


@pytest.mark.parametrize("H,h,L1,L2", [(0.5, 3.0, 0.5, 12.0), (2.0, 6.0, 1.0, 20.0), (4.0, 10.0, 0.2, 30.0)])
def test_two_layers_in_series_by_independent_root_finding(H, h, L1, L2):
    """1-D Forchheimer flow through a gravel layer then rock: find the head at the interface where both
    layers carry the same Darcy velocity (nested brentq on each layer's own law), compare q = V h."""
    a1, b1 = forchheimer_coefficients(GRAVEL.porosity, GRAVEL.d50)
    a2, b2 = forchheimer_coefficients(ROCK.porosity, ROCK.d50)

    def v_layer(dh, L, a, b):  # velocity through one layer under head drop dh: brentq on a V + b V^2 = dh/L
        return brentq(lambda V: a * V + b * V * V - dh / L, 0.0, 1e3)

    hi = brentq(lambda x: v_layer(x, L1, a1, b1) - v_layer(H - x, L2, a2, b2), 1e-12, H - 1e-12, xtol=1e-14)
    q_ref = v_layer(hi, L1, a1, b1) * h
    q = series_unit_discharge(H, h, [(L1, float(a1), float(b1)), (L2, float(a2), float(b2))])
    assert q == pytest.approx(q_ref, rel=1e-8)


def test_seal_reduces_leakage_and_tonnage_by_hand():
    d = SealDesign(GRAVEL, 1.0, ROCK, filters=((QUARRY, 0.5),))
    H, h, L = 2.0, 6.0, 20.0
    r = d.reduction(H, h, L)
    assert 0 < r < 1
    # the same via the series solver with the layers written out here
    lay = [(1.0, *GRAVEL.forchheimer()), (0.5, *QUARRY.forchheimer()), (18.5, *ROCK.forchheimer())]
    q_rock = series_unit_discharge(H, h, [(L, *ROCK.forchheimer())])
    assert r == pytest.approx(series_unit_discharge(H, h, lay) / q_rock, rel=1e-12)
    assert sealed_leakage(40.0, d, H, h, L) == pytest.approx(40.0 * r)
    t = d.tonnage(face_area=300.0)
    assert t["gravel"] == pytest.approx(300 * 1.0 * (1 - 0.33) * 2650 / 1000)
    assert t["quarry_run"] == pytest.approx(300 * 0.5 * (1 - 0.35) * 2650 / 1000)


def test_required_thickness_meets_the_target_and_no_less():
    d = SealDesign(SAND, 0.1, ROCK, filters=((GRAVEL, 0.5), (QUARRY, 0.5)))
    H, h, L, q0 = 2.0, 6.0, 20.0, 40.0
    target = 0.05
    t = required_thickness(d, q0, target, H, h, L)
    assert 0 < t < 9.5
    from dataclasses import replace
    assert sealed_leakage(q0, replace(d, thickness=t), H, h, L) <= target * (1 + 1e-9)
    assert sealed_leakage(q0, replace(d, thickness=0.98 * t), H, h, L) > target
    assert required_thickness(d, 1.0, 2.0, H, h, L) == 0.0
    assert math.isinf(required_thickness(d, q0, 1e-9, H, h, L))
