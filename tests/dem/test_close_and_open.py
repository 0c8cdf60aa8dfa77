"""Step n's closing pass fused with step n+1's first pass (dem/steploop.py ``close_and_first_pass``, used by the
compiled loop ``steploop_fluid.fluid_verlet_steps`` on dry, non-sleeping steps that end no call, issue 16):
bit for bit ``second_pass`` then ``first_pass`` (two half kicks, two roundings) at unfavourable cases —
gravity / damping on or off, both integrators, motion masks per axis, each combination of periodic axes,
particles crossing seams, leaving the box and turning non-finite in the opening part; and whole runs of the
compiled loop against stepping in Python for short calls (1, 2, 3 steps: the last step's plain pass) and
long ones, with leavers (a call ends on them), sleeping on (plain passes, sleep checks at every phase) and
off, damping on and off, periodic or closed, and the call ending on each event."""
import numpy as np
import pytest

from breachflow.dem import steploop

from .test_fused_passes import BOUNDS, MASKS, first_args, scene
from .test_steploop import assert_same, drop

H, DT, G = 0.05, 0.1, np.array([0.3, -0.7, -9.81])


def closing_args(a, seed):
    rng = np.random.default_rng(seed + 100)
    return rng.uniform(1, 3, 200), rng.uniform(0, 5, 200), rng.uniform(0, 2, 200)


@pytest.mark.parametrize("gravity", [False, True])
@pytest.mark.parametrize("damp", [False, True])
@pytest.mark.parametrize("predict", [False, True])
@pytest.mark.parametrize("masks", MASKS)
@pytest.mark.parametrize("periodic,use_box", BOUNDS)
def test_fused_pass_equals_second_then_first_pass(gravity, damp, predict, masks, periodic, use_box):
    for seed in (1, 2):
        ref, new = scene(seed, periodic, MASKS[masks]), scene(seed, periodic, MASKS[masks])
        mass, c_gn, c_gw = closing_args(ref, seed)
        rng = np.random.default_rng(seed + 200)
        vp, wp = rng.normal(0, 1, (200, 3)), rng.normal(0, 1, (200, 3))
        for a in (ref, new):
            a["vp"][:], a["wp"][:] = vp, wp  # the damping's velocities with predicted_verlet
        ve, we = (ref["vp"], ref["wp"]) if predict else (ref["vel"], ref["omega"])
        steploop.second_pass(ref["idx"], ref["active"], gravity, mass, G, ve, we, c_gn, c_gw, damp, ref["force"],
                             ref["torque"], ref["vel"], ref["omega"], ref["inv_m"], ref["inv_i"], H, ref["lmask"],
                             ref["rmask"])
        out_ref = steploop.first_pass(*first_args(ref, H, DT, predict, 0.75, use_box))
        out = steploop.close_and_first_pass(*first_args(new, H, DT, predict, 0.75, use_box), True, gravity, mass, G,
                                            c_gn, c_gw, damp)
        assert out_ref[1] == out[1] and (out[1] > 5 if use_box else out[1] == 0)  # leavers in the opening part
        for x, y in zip(out_ref, out):
            if isinstance(x, np.ndarray):
                np.testing.assert_array_equal(x, y, strict=True)
            else:
                assert x == y
        for k in ref:
            if isinstance(ref[k], np.ndarray):
                np.testing.assert_array_equal(ref[k], new[k], err_msg=k, strict=True)


@pytest.mark.parametrize("predict", [False, True])
def test_fused_pass_with_non_finite_particles(predict):
    """A particle turning non-finite is reported (the first in idx order); its rows and the others' are the
    plain passes' (the bad one's force rows keep the closing pass's sums)."""
    ref, new = scene(4, (1, 0), MASKS["plane_2d"]), scene(4, (1, 0), MASKS["plane_2d"])
    mass, c_gn, c_gw = closing_args(ref, 4)
    for a in (ref, new):
        a["force"][a["idx"][[30, 90]], 2] = np.nan
        a["vel"][a["idx"][60], 0] = np.inf
    ve, we = (ref["vp"], ref["wp"]) if predict else (ref["vel"], ref["omega"])
    steploop.second_pass(ref["idx"], ref["active"], True, mass, G, ve, we, c_gn, c_gw, True, ref["force"],
                         ref["torque"], ref["vel"], ref["omega"], ref["inv_m"], ref["inv_i"], H, ref["lmask"],
                         ref["rmask"])
    out_ref = steploop.first_pass(*first_args(ref, H, DT, predict, 0.75, True))
    out = steploop.close_and_first_pass(*first_args(new, H, DT, predict, 0.75, True), True, True, mass, G, c_gn,
                                        c_gw, True)
    assert out[0] == out_ref[0] == ref["idx"][30]
    for k in ref:
        if isinstance(ref[k], np.ndarray):
            np.testing.assert_array_equal(ref[k], new[k], err_msg=k, strict=True)


def pair(integrator, *, sleeping, periodic, damping, seed):
    ref = drop(integrator, sleeping=sleeping, periodic=periodic, compiled=False, seed=seed)
    new = drop(integrator, sleeping=sleeping, periodic=periodic, compiled=True, seed=seed)
    if not damping:
        for sim in (ref, new):
            sim.state.c_gn[:] = 0.0
            sim.state.c_gw[:] = 0.0
    return ref, new


@pytest.mark.parametrize("integrator", ["velocity_verlet", "predicted_verlet"])
@pytest.mark.parametrize("damping", [False, True])
@pytest.mark.parametrize("sleeping,periodic", [(False, True), (False, False), (True, False)])
def test_short_and_long_calls_equal_python(integrator, damping, sleeping, periodic):
    """Calls of 1, 2, 3 steps (the closing pass of the call's last step is the plain one) and long ones with
    leavers (each ends its call), rebuilds, sleepers; the compiled loop equals the Python step after each."""
    ref, new = pair(integrator, sleeping=sleeping, periodic=periodic, damping=damping, seed=3)
    for n in (1, 2, 3, 1, 2, 3, 400, 1, 2, 3, 2500):
        assert ref.step(n) == new.step(n)
        assert_same(ref, new)
    assert len(new.left_domain) >= 3


@pytest.mark.parametrize("integrator", ["velocity_verlet", "predicted_verlet"])
@pytest.mark.parametrize("sleep_check", [1, 2, 3, 7])
def test_sleep_checks_at_every_phase_equal_python(integrator, sleep_check):
    """With sleeping, the sleep test reads the closed velocities (SLEEP, WAKE end calls): every phase of the
    sleep check against the call's start."""
    ref, new = pair(integrator, sleeping=True, periodic=False, damping=True, seed=5)
    for sim in (ref, new):
        sim.sleep_check = sleep_check
    for n in (1, 2, 3, 1500, 2, 1, 3000, 6000, 1, 3, 6000):
        assert ref.step(n) == new.step(n)
        assert_same(ref, new)
    assert (new.state.active & ~new.state.awake).any()


@pytest.mark.parametrize("integrator", ["velocity_verlet", "predicted_verlet"])
@pytest.mark.parametrize("crit", ["max", "sum"])
@pytest.mark.parametrize("consecutive", [1, 3])
@pytest.mark.parametrize("sleeping,periodic", [(False, True), (True, False)])
def test_equilibrium_runs_equal_python(integrator, crit, consecutive, sleeping, periodic):
    """run_to_equilibrium: the call ends on CONVERGED (decided before the closing kick) and on the other
    events; same steps, outcome and state as in Python."""
    ref, new = pair(integrator, sleeping=sleeping, periodic=periodic, damping=True, seed=11)
    assert ref.step(700) == new.step(700)
    kw = dict(max_steps=30000, criterion=crit, consecutive=consecutive)
    e_tol = 1e-5 if crit == "max" else 4e-4
    r_ref, r_new = ref.run_to_equilibrium(e_tol, **kw), new.run_to_equilibrium(e_tol, **kw)
    assert r_ref == r_new and r_new.converged
    assert_same(ref, new)
