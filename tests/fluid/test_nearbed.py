"""The near-bed flow terms (breachflow.fluid.nearbed) against their formulas, evaluated independently here:
the drag over the exposed height (an adaptive quadrature of the log law over the sphere's projected disc),
the turbulent velocity peaks (Nezu & Nakagawa 1993), the lift (Wiberg & Smith 1987), the fused kernel against
the step-by-step path, and the earlier forces bit for bit with the terms off."""
import math

import numpy as np
import pytest
from scipy.integrate import quad

from breachflow.dem.state import Material, ParticleState
from breachflow.fluid import nearbed as NB
from breachflow.fluid.field import UniformWater
from breachflow.fluid.forces import FluidForces
from breachflow.fluid.profile import factors as profile_factors

from .test_compiled_forces import breach_like_field, forces, random_state

KAPPA = 0.41


def log_f(z, h, ks):
    """u(z)/U of the rough log law, 0 below z0 = ks/30, held at its surface value above h (written out here,
    not taken from the package)."""
    z = min(z, h)
    return math.log(30.0 * z / ks) / (math.log(30.0 * h / ks) - 1.0) if z > ks / 30.0 else 0.0


def exposed_rms(zc, a, h, ks):
    """sqrt(<f^2>) over the projected disc of a sphere of radius a centred zc above the bed (quadrature in z)."""
    lo = max(zc - a, ks / 30.0)
    if lo >= zc + a:
        return 0.0
    val, _ = quad(lambda z: log_f(z, h, ks) ** 2 * 2.0 * math.sqrt(max(a * a - (z - zc) ** 2, 0.0)), lo, zc + a,
                  limit=200, epsabs=1e-13, epsrel=1e-11)
    return math.sqrt(val / (math.pi * a * a))


@pytest.mark.parametrize("zc,a,h,ks", [(0.5, 0.5, 5.0, 0.2), (2.0, 2.0, 7.0, 0.066), (0.3, 0.25, 1.0, 0.05),
                                       (3.0, 1.0, 10.0, 0.5), (2.0, 2.0, 3.0, 8.0)])
def test_exposed_height_drag_velocity_is_the_disc_rms_of_the_log_law(zc, a, h, ks):
    p = NB.parameters(terms=())  # exposed height only
    g, lam = NB.factors(1, ks, zc, h, a, p)
    assert lam == 0.0
    assert g == pytest.approx(exposed_rms(zc, a, h, ks), rel=3e-3, abs=1e-6)


def test_terms_off_give_the_centre_profile_factor_bit_for_bit():
    rng = np.random.default_rng(3)
    z, h, a = rng.uniform(-1, 8, 50), rng.uniform(0.1, 9, 50), rng.uniform(0.1, 3, 50)
    for code in (0, 1, 2):
        g, lam = NB.factors(code, 0.07, z, h, a, NB.off())
        assert np.array_equal(g, profile_factors(code, z, h, 0.07)) and not lam.any()


@pytest.mark.parametrize("zc,h,ks,kp", [(2.0, 7.0, 0.066, 0.93), (0.1, 1.0, 0.01, 2.0), (1.0, 20.0, 0.5, 1.0)])
def test_turbulent_peak_is_nezu_nakagawa_intensity_times_the_peak_factor(zc, h, ks, kp):
    """Uniform profile (exposed factor 1): g - 1 = k_p 2.30 exp(-z/h) u*/U, u*/U = kappa / (ln(30 h/k_s) - 1)."""
    p = NB.parameters(terms=("turbulence",), turbulence={"peak_factor": kp})
    g, lam = NB.factors(0, ks, zc, h, 0.5, p)
    expect = kp * 2.30 * math.exp(-zc / h) * KAPPA / (math.log(30.0 * h / ks) - 1.0)
    assert g - 1.0 == pytest.approx(expect, rel=1e-12, abs=1e-15) and lam == 0.0


def test_no_log_layer_takes_the_manning_strickler_shear_velocity():
    h, ks = 0.2, 1.0  # ln(30 h / k_s) - 1 = 0.79 < 1
    p = NB.parameters(terms=("turbulence",), turbulence={"peak_factor": 1.0})
    g, _ = NB.factors(0, ks, 0.05, h, 0.05, p)
    assert g - 1.0 == pytest.approx(2.30 * math.exp(-0.25) / (8.1 * (h / ks) ** (1 / 6)), rel=1e-12)


@pytest.mark.parametrize("U,h,D", [(3.0, 4.0, 1.0), (9.0, 7.0, 4.0), (1.0, 1.0, 0.1)])
def test_lift_on_a_resting_sphere_is_wiberg_smith(U, h, D):
    """F_z - buoyancy = 1/2 rho C_L A (u_T^2 - u_B^2) of the flow it feels (the peak scales the profile)."""
    a, ks = 0.5 * D, 2.0 * D
    water = UniformWater(surface=h, u=U, bed=0.0)
    p = NB.parameters(terms=("lift",))
    model = FluidForces(water, velocity_profile="log", roughness=ks, air=None, near_bed=p, drag_law="stokes")
    st = ParticleState.spheres(np.array([[0.0, 0.0, a]]), np.array([a]), Material(density=2650.0))
    f, _ = forces(model, st, st.pos)
    buoy = 1000.0 * 9.80665 * 4.0 / 3.0 * math.pi * a ** 3
    big_f = exposed_rms(a, a, h, ks)
    u_felt = U * big_f
    lift = 0.5 * 1000.0 * 0.2 * math.pi * a * a * U ** 2 * (log_f(2 * a, h, ks) ** 2 - 0.0)
    assert f[0, 2] - buoy == pytest.approx(lift, rel=3e-3)
    # moving with the flow it feels: no relative velocity, no lift
    st.vel[0, 0] = NB.factors(1, ks, a, h, a, p)[0] * U
    f, _ = forces(model, st, st.pos)
    assert f[0, 2] - buoy == pytest.approx(0.0, abs=1e-9 * lift)
    assert u_felt > 0


def test_no_lift_in_a_uniform_profile():
    water = UniformWater(surface=3.0, u=4.0, bed=0.0)
    model = FluidForces(water, velocity_profile="uniform", roughness=0.1, air=None, near_bed=NB.parameters())
    st = ParticleState.spheres(np.array([[0.0, 0.0, 0.5]]), np.array([0.5]), Material(density=2650.0))
    f, _ = forces(model, st, st.pos)
    assert f[0, 2] == pytest.approx(1000.0 * 9.80665 * 4.0 / 3.0 * math.pi * 0.125, rel=1e-12)


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("profile", ["log", "uniform"])
def test_fused_kernel_with_near_bed_terms_matches_the_step_by_step_path(seed, profile):
    rng = np.random.default_rng(seed)
    st = random_state(rng)
    field = breach_like_field()
    kw = dict(velocity_profile=profile, roughness=0.3, near_bed=NB.parameters(), outside="air")
    fused = FluidForces(field, **kw)
    ref = FluidForces(field, compiled=False, **kw)
    assert fused._fused is not None and ref._fused is None
    f1, t1 = forces(fused, st, st.pos)
    f2, t2 = forces(ref, st, st.pos)
    np.testing.assert_allclose(f1, f2, rtol=1e-11, atol=1e-9)
    np.testing.assert_allclose(t1, t2, rtol=1e-11, atol=1e-9)
    # the terms change the forces of the wet particles near the bed
    off = FluidForces(field, velocity_profile=profile, roughness=0.3, outside="air")
    f3, _ = forces(off, st, st.pos)
    assert not np.allclose(f1, f3)


@pytest.mark.parametrize("bad", [{"lift": {"coefficient": -0.1}}, {"turbulence": {"peak_factor": float("nan")}}])
def test_bad_parameters_are_refused(bad):
    from breachflow.errors import InputError

    with pytest.raises(InputError):
        NB.parameters(**bad)
