"""The fused passes of the compiled DEM loop (dem/steploop.py ``first_pass`` / ``second_pass``, issue 16), which
load each particle's rows once into scalars and index them unsigned: bit for bit the separate kernels the
Python step runs, at unfavourable cases — a shuffled subset of the particles (rows outside it untouched),
motion masks that differ per axis (``plane_2d`` and others), each combination of periodic axes, particles
crossing the seams and leaving the domain, non-finite particles, gravity / damping on or off, the
predicted velocities aliased or not; and whole simulations in ``plane_2d`` mode (compiled against Python,
mixed calls, a restart from a saved state after a compiled call)."""
import numpy as np
import pytest

from breachflow.dem import DemSimulation, Material, Plane, steploop
from breachflow.dem import wall_contacts as walls
from breachflow.dem.forces import _add_gravity, add_global_damping, zero_rows
from breachflow.dem.integrators import drift, kick, predict_extrapolated
from breachflow.dem.neighbours import displacement_since, wrap_and_check
from breachflow.dem.pairlist import PairList

from .test_steploop import assert_same

MASKS = {"3d": ((1.0, 1.0, 1.0), (1.0, 1.0, 1.0)), "plane_2d": ((1.0, 0.0, 1.0), (0.0, 1.0, 0.0)),
         "other axes": ((0.0, 1.0, 1.0), (1.0, 1.0, 0.0))}
#: (periodic x, periodic y), a domain box or not
BOUNDS = [((1, 1), False), ((0, 1), True), ((1, 0), True), ((0, 0), True)]
LO, L = -2.5, 5.0


def scene(seed, periodic, masks, n=200):
    rng = np.random.default_rng(seed)
    pos = rng.uniform(LO, LO + L, (n, 3))
    pos[:, 2] = rng.uniform(0.0, 5.0, n)
    pos[:20, 0] = LO + L - rng.uniform(0, 0.05, 20)  # next to the seams / the box's faces
    pos[20:40, 1] = LO + rng.uniform(0, 0.05, 20)
    vel = rng.normal(0, 3.0, (n, 3))
    a = dict(
        idx=rng.permutation(n)[:150].astype(np.int64), pos=pos, vel=vel, omega=rng.normal(0, 2.0, (n, 3)),
        force=rng.normal(0, 1e3, (n, 3)), torque=rng.normal(0, 1e2, (n, 3)), fp=rng.normal(0, 1e3, (n, 3)),
        tp=rng.normal(0, 1e2, (n, 3)), vp=np.zeros((n, 3)), wp=np.zeros((n, 3)), inv_m=rng.uniform(0.5, 2.0, n),
        inv_i=rng.uniform(0.5, 4.0, n), lmask=np.array(masks[0]), rmask=np.array(masks[1]),
        geom=np.array([LO, LO, 0.0, 1.0, 1.0, 1.0, L, L]), periodic=np.array(periodic, np.int64),
        box=np.array([LO + 0.02, LO + L - 0.02, LO + 0.02, LO + L - 0.02, 0.3, 4.7]),
        active=np.ones(n, bool), awake=np.ones(n, bool), left_ids=np.zeros(n, np.int64),
        pos_build=pos + rng.normal(0, 0.05, (n, 3)))
    return a


def first_args(a, h, dt, predict, c, use_box):
    return (a["idx"], a["pos"], a["vel"], a["omega"], a["force"], a["torque"], a["fp"], a["tp"], a["vp"], a["wp"],
            a["inv_m"], a["inv_i"], a["lmask"], a["rmask"], h, dt, predict, c, a["geom"], a["periodic"], a["box"],
            use_box, a["active"], a["awake"], a["left_ids"], a["pos_build"])


def separate_first(a, h, dt, predict, c, use_box):
    """The Python step's kernels in the order of ``VelocityVerlet.step`` (kick, drift, wrap / retire, predict),
    then the zeroing of the active rows and the rebuild check."""
    idx = a["idx"]
    kick(idx, a["vel"], a["omega"], a["force"], a["torque"], a["inv_m"], a["inv_i"], h, a["lmask"], a["rmask"])
    mx, sm = drift(idx, a["pos"], a["vel"], dt)
    nleft, bad = wrap_and_check(idx, a["pos"], a["vel"], a["omega"], a["geom"], a["periodic"], a["box"], use_box,
                                a["active"], a["awake"], a["left_ids"])
    if predict:
        predict_extrapolated(idx, a["vel"], a["omega"], a["force"], a["torque"], a["fp"], a["tp"], a["inv_m"],
                             a["inv_i"], h, c, a["lmask"], a["rmask"], a["vp"], a["wp"])
    keep = idx[a["active"][idx]]
    zero_rows(keep, a["force"], a["torque"])
    return bad, nleft, keep, mx, sm, displacement_since(keep, a["pos"], a["pos_build"], a["geom"], a["periodic"])


def assert_rows_equal(a, b, skip=()):
    for k in a:
        if isinstance(a[k], np.ndarray) and k not in skip:
            np.testing.assert_array_equal(a[k], b[k], err_msg=k, strict=True)


@pytest.mark.parametrize("predict", [False, True])
@pytest.mark.parametrize("masks", MASKS)
@pytest.mark.parametrize("periodic,use_box", BOUNDS)
def test_first_pass_equals_the_separate_kernels(predict, masks, periodic, use_box):
    h, dt, c = 0.05, 0.1, 0.75  # long steps: many particles cross the seams and leave the box
    for seed in (1, 2, 3):
        ref, new = scene(seed, periodic, MASKS[masks]), scene(seed, periodic, MASKS[masks])
        untouched = np.setdiff1d(np.arange(200), ref["idx"])
        bad, nleft, keep, mx, sm, moved = separate_first(ref, h, dt, predict, c, use_box)
        out = steploop.first_pass(*first_args(new, h, dt, predict, c, use_box))
        assert (out[0], out[1], out[6], out[7], out[8]) == (bad, nleft, mx, sm, moved)
        assert bad == -1 and (nleft > 5 if use_box else nleft == 0)
        np.testing.assert_array_equal(out[2], keep, strict=True)
        assert out[9] == (walls.max_speed(keep, new["vp"]) if predict else 0.0)  # the plane lists' speed bound
        np.testing.assert_array_equal(out[3], ref["idx"], strict=True)  # the kicked ones, leavers included
        ve, we = (new["vp"], new["wp"]) if predict else (new["vel"], new["omega"])
        assert np.shares_memory(out[4], ve) and np.shares_memory(out[5], we)
        assert_rows_equal(ref, new)
        for k in ("pos", "vel", "omega", "force", "torque", "fp", "tp", "vp", "wp"):
            np.testing.assert_array_equal(new[k][untouched], scene(seed, periodic, MASKS[masks])[k][untouched])


@pytest.mark.parametrize("predict", [False, True])
def test_first_pass_reports_the_first_non_finite_particle(predict):
    """The first non-finite particle in *idx* order is reported; the finite ones are done as the separate
    kernels do them."""
    h, dt = 0.05, 0.1
    ref, new = scene(4, (1, 0), MASKS["plane_2d"]), scene(4, (1, 0), MASKS["plane_2d"])
    for a in (ref, new):
        a["force"][a["idx"][[30, 90]], 2] = np.nan
        a["vel"][a["idx"][60], 0] = np.inf
    out = steploop.first_pass(*first_args(new, h, dt, predict, 0.75, True))
    separate_first(ref, h, dt, predict, 0.75, True)
    assert out[0] == ref["idx"][30]
    ok = np.setdiff1d(ref["idx"], ref["idx"][[30, 60, 90]])
    for k in ("pos", "vel", "omega", "force", "torque", "fp", "tp", "vp", "wp"):
        np.testing.assert_array_equal(new[k][ok], ref[k][ok], err_msg=k)


@pytest.mark.parametrize("gravity", [False, True])
@pytest.mark.parametrize("damp", [False, True])
@pytest.mark.parametrize("aliased", [False, True])
@pytest.mark.parametrize("masks", MASKS)
def test_second_pass_equals_the_separate_kernels(gravity, damp, aliased, masks):
    """Gravity and the global damping on the active particles, then the closing kick of all kicked ones
    (retired ones included); the damping velocities are the integrated ones (velocity_verlet: aliased) or
    the predicted ones."""
    h, g = 0.05, np.array([0.3, -0.7, -9.81])
    for seed in (5, 6):
        ref, new = scene(seed, (1, 1), MASKS[masks]), scene(seed, (1, 1), MASKS[masks])
        rng = np.random.default_rng(seed)
        mass, c_gn, c_gw = rng.uniform(1, 3, 200), rng.uniform(0, 5, 200), rng.uniform(0, 2, 200)
        vp, wp = rng.normal(0, 1, (200, 3)), rng.normal(0, 1, (200, 3))
        for a in (ref, new):
            a["active"][a["idx"][::7]] = False  # retired in this step's first pass, still kicked
            a["vp"][:], a["wp"][:] = vp, wp
        kicked = ref["idx"]
        for a, fused in ((ref, False), (new, True)):
            ve, we = (a["vel"], a["omega"]) if aliased else (a["vp"], a["wp"])
            if fused:
                steploop.second_pass(kicked, a["active"], gravity, mass, g, ve, we, c_gn, c_gw, damp, a["force"],
                                     a["torque"], a["vel"], a["omega"], a["inv_m"], a["inv_i"], h, a["lmask"],
                                     a["rmask"])
                continue
            act = kicked[a["active"][kicked]]
            if gravity:
                _add_gravity(act, mass, g, a["force"])
            if damp:
                add_global_damping(act, ve, we, c_gn, c_gw, 1.0, a["force"], a["torque"])
            kick(kicked, a["vel"], a["omega"], a["force"], a["torque"], a["inv_m"], a["inv_i"], h, a["lmask"],
                 a["rmask"])
        assert_rows_equal(ref, new)


ROCK = Material(density=2650, kn=1e6, ks=1e6, friction=0.5, c_cn=2e3, c_cs=1e3, c_cf=1e3)


def drop_2d(integrator, compiled, seed):
    """Spheres dropped in the vertical x-z plane (``plane_2d``: masks (1, 0, 1) / (0, 1, 0)) onto a floor,
    periodic in x, a few thrown out of the domain, sleeping on."""
    rng = np.random.default_rng(seed)
    sim = DemSimulation(boundaries=[Plane((0, 0, 0), (0, 0, 1), ROCK)], dt=5e-4, sleeping=True, plane_2d=True,
                        integrator=integrator, periodic_x=(-2.5, 2.5), domain=(-9, 9, -9, 9, -1, 7),
                        sleep_check=5, sleep_velocity=0.02, sleep_steps=10)
    sim.compiled = compiled
    n = 30
    k = np.arange(n)
    pos = np.column_stack([-1.9 + 1.25 * (k % 4) + rng.uniform(-0.3, 0.3, n), np.zeros(n), 0.25 + 0.45 * (k // 4)])
    vel = rng.normal(0, 1.0, (n, 3))
    vel[-2:, 2] = 40.0  # these leave the domain
    sim.add_particles(pos, 0.2, ROCK, vel=vel, omega=rng.normal(0, 1.0, (n, 3)))
    sim.state.c_gn[:] = 3.0 * sim.state.mass
    sim.state.c_gw[:] = 3.0 * sim.state.inertia
    return sim


@pytest.mark.parametrize("integrator", ["velocity_verlet", "predicted_verlet"])
def test_plane_2d_compiled_mixed_and_restarted_equals_python(integrator, monkeypatch, tmp_path):
    """``plane_2d`` (the masks the fused passes multiply by) through the compiled loop: with leavers, rebuilds
    inside the call, particles falling asleep and being woken, calls of the compiled loop mixed with Python
    steps, and a restart from a state saved after a compiled call; bit-identical to stepping in Python."""
    calls, rebuilds = [], {}
    real, real_rebuild = steploop.run, PairList.rebuild
    monkeypatch.setattr(steploop, "run", lambda *a, **k: calls.append(1) or real(*a, **k))

    def counted(self):  # rebuilds done in Python
        rebuilds[id(self.sim)] = rebuilds.get(id(self.sim), 0) + 1
        return real_rebuild(self)

    monkeypatch.setattr(PairList, "rebuild", counted)
    ref = drop_2d(integrator, False, 7)
    new = drop_2d(integrator, True, 7)
    slept = woke = False
    for n, compiled in ((900, True), (5, False), (1100, True), (3, False), (1000, True)):
        new.compiled = compiled
        assert ref.step(n) == new.step(n)
        assert_same(ref, new)
        slept |= bool((new.state.active & ~new.state.awake).any())
    assert len(calls) > 0 and len(new.left_domain) >= 2 and slept
    assert rebuilds[id(new)] < rebuilds[id(ref)] - 5  # the others ran inside the compiled calls
    path = tmp_path / "dem.npz"
    np.savez(path, **new.save_state())
    with np.load(path) as data:
        back = DemSimulation.from_state(dict(data), boundaries=[Plane((0, 0, 0), (0, 0, 1), ROCK)], dt=5e-4,
                                        sleeping=True, plane_2d=True, integrator=integrator, periodic_x=(-2.5, 2.5),
                                        domain=(-9, 9, -9, 9, -1, 7), sleep_check=5,
                                        sleep_velocity=0.02, sleep_steps=10)
    n_calls = len(calls)
    asleep = np.flatnonzero(ref.state.active & ~ref.state.awake)
    top = asleep[np.argmax(ref.state.pos[asleep, 2])]
    for sim in (ref, back):  # a sphere dropped onto the highest sleeper wakes it
        sim.add_particles(ref.state.pos[[top]] + [0.0, 0.0, 2.0], 0.2, ROCK, vel=np.array([[0.0, 0.0, -6.0]]))
    for n in (300, 1200):
        assert ref.step(n) == back.step(n)
        assert_same(ref, back)
        woke |= bool(back.state.awake[asleep].any())
    assert len(calls) > n_calls and woke
    assert np.all(back.state.vel[:, 1] == 0.0) and np.all(back.state.omega[:, [0, 2]] == 0.0)
