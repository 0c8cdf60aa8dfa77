"""The closure cycle's DEM (height-field terrain + frozen grid fluid field, static models) run many steps
per compiled call (dem/steploop_fluid.py, issue 16) is bit-identical to stepping in Python: masses
entering the water, crossing the surface, resting on the terrain (dry bank and river bed), leaving the
box (lost), sleeping, woken by a changed field and by new masses dropped on them; both Verlet
integrators, every velocity profile, both samplers, with and without air / apparent mass; and a whole
closure run with the porous and raised-bed remaps gives the same files."""
from pathlib import Path

import numpy as np
import pytest

from breachflow.cycle.config import closure_setup
from breachflow.cycle.driver import ClosureRun
from breachflow.coupling import steploop as steploop_fluid
from breachflow.dem import DemSimulation, HeightField, Material, Plane, steploop
from breachflow.fluid.forces import FluidForces
from breachflow.field.sampling import FieldSampler
from breachflow.field.snapshot import grid_snapshot
from breachflow.scenario.config import parse_scenario
from breachflow.scenario.toml import scenario_with

ROCK = Material(density=2650, kn=2e7, friction=0.6, rolling_friction=0.3, c_cn=3e4)


def field(level=2.5, speed=3.0, spacing=0.7):
    """A river 0-3 m deep over a sloping bed with a jet-like flow and a dry bank (x > 6 m)."""
    x = np.arange(-10.0, 10.0 + 1e-9, spacing)
    y = np.arange(-8.0, 8.0 + 1e-9, spacing * 1.3)
    X, Y = np.meshgrid(x, y)
    bed = 0.05 * X + 0.1 * np.sin(Y)
    depth = np.where(X > 6.0, 0.0, np.maximum(level + 0.02 * Y - bed, 0.0))
    u = np.where(depth > 0, speed * np.exp(-(Y / 4.0) ** 2) + 0.2 * X / 10, 0.0)
    v = np.where(depth > 0, 0.5 * np.sin(X / 3.0), 0.0)
    return x, y, bed, grid_snapshot(x, y, bed, depth, u, v)


def scene(compiled, integrator, fluid_kw, wall, seed):
    x, y, bed, snap = field()
    terrain = HeightField(x, y, bed, ROCK)
    bounds = [Plane((0, -7.0, 0), (0, 1, 0), ROCK), terrain] if wall else [terrain]
    sim = DemSimulation(boundaries=bounds, models=[FluidForces(snap, outside="air", **fluid_kw)],
                        integrator=integrator, domain=(-10, 10, -8, 8, -50, 200), static_models=True,
                        sleep_velocity=0.25)  # masses kept spinning in place by the fluid torque fall asleep
    sim.compiled = compiled
    rng = np.random.default_rng(seed)
    n = 16
    pos = np.column_stack([rng.uniform(-6, 5, n), rng.uniform(-5, 5, n), 4.0 + rng.uniform(0, 2, n)])
    pos[2:5, 0] = rng.uniform(7.0, 9.0, 3)  # onto the dry bank
    vel = rng.normal(0, 1, (n, 3))
    vel[2:5, 0] = 0.0
    vel[:2, 0] = 15.0  # carried out of the box: lost
    sim.add_particles(pos, rng.uniform(0.3, 0.6, n), ROCK, vel=vel)
    return sim


def settle(sim, seconds):
    """As the cycle's ``CycleDem.settle``: equilibrium runs in record-interval chunks (here never stopping early)."""
    chunk = int(round(0.1 / sim.dt))
    for _ in range(int(seconds / 0.1)):
        sim.run_to_equilibrium(1e-5, max_steps=chunk, consecutive=min(chunk, 50))


def assert_same(a, b):
    sa, sb = a.save_state(), b.save_state()
    assert sa.keys() == sb.keys()
    for k in sa:
        np.testing.assert_array_equal(sa[k], sb[k], err_msg=k, strict=True)
    assert a.left_domain == b.left_domain and a.particle_steps == b.particle_steps and a.t == b.t
    assert a.models[0].evaluations == b.models[0].evaluations


CASES = [("predicted_verlet", {"velocity_profile": "log"}, False, 1),  # the closure run's defaults
         ("predicted_verlet", {"velocity_profile": "log", "sampling": "neighbourhood"}, True, 2),
         ("predicted_verlet", {"velocity_profile": "power", "air": None}, False, 3),
         ("velocity_verlet", {"velocity_profile": "uniform", "xi": 0.0}, True, 4),
         ("velocity_verlet", {"velocity_profile": "log", "torque": False, "time_step": 1e-3}, False, 5)]


@pytest.mark.parametrize("integrator,fluid_kw,wall,seed", CASES)
def test_cycle_scene_compiled_steps_are_bit_identical(integrator, fluid_kw, wall, seed, monkeypatch):
    done = []
    monkeypatch.setattr(steploop_fluid, "run", _counting(steploop_fluid.run, done))
    ref = scene(False, integrator, fluid_kw, wall, seed)
    new = scene(True, integrator, fluid_kw, wall, seed)
    for sim in (ref, new):
        sim.step(1)
        sim.step(250)  # falling through air, entering the water
    assert_same(ref, new)
    for sim in (ref, new):
        settle(sim, 8.0)
    assert_same(ref, new)
    st = new.state
    assert len(new.left_domain) >= 2
    asleep = np.flatnonzero(st.active & ~st.awake)
    assert asleep.size >= 3  # at rest on the terrain: asleep
    dry = asleep[st.pos[asleep, 0] > 6.2]
    wet = asleep[st.pos[asleep, 0] < 5.5]
    assert dry.size and wet.size  # on the dry bank and on the river bed
    before = st.pos[asleep].copy()
    # the next cycle: a faster, higher flow (wakes masses by force) and new masses dropped on the resting ones
    x, y, bed, snap = field(level=2.9, speed=4.5)
    rng = np.random.default_rng(seed + 100)
    drop = st.pos[asleep[:4]] + [0.0, 0.0, 2.0] + rng.normal(0, 0.05, (4, 3))
    for sim in (ref, new):
        sim.set_models([FluidForces(snap, outside="air", **fluid_kw)])
        sim.add_particles(drop, 0.4, ROCK)
        settle(sim, 6.0)
    assert_same(ref, new)
    assert np.abs(new.state.pos[asleep] - before).max() > 1e-3  # sleepers were woken and moved
    assert sum(done) > 0.95 * new.particle_steps  # nearly all the work ran in the compiled loop


def _counting(real, done):
    """*real* (a many-steps runner) recording the particle-steps each call advanced in *done*."""
    def run(sim, *a, **k):
        ps = sim.particle_steps
        out = real(sim, *a, **k)
        done.append(sim.particle_steps - ps)
        return out
    return run


def test_ineligible_cycle_scenes_step_in_python():
    """A fallback sampler (nested grids), a uniform field, the Basset term, outside='error', non-static
    models, the report scheme, adaptive free flight and a second height field step in Python."""
    x, y, bed, snap = field()

    def sim_with(models=None, **kw):
        kw.setdefault("static_models", True)
        bounds = kw.pop("boundaries", [HeightField(x, y, bed, ROCK)])
        s = DemSimulation(boundaries=bounds, models=models if models is not None else
                          [FluidForces(snap, outside="air", velocity_profile="uniform")], domain=(-10, 10, -8, 8, -50, 200), **kw)
        s.add_particles([[0.0, 0.0, 4.0]], 0.4, ROCK)
        s.step(1)  # the first step after set-up checks the sleepers' field forces (in Python)
        return s

    assert steploop.runner(sim_with()) is steploop_fluid.run
    assert steploop.runner(sim_with([])) is steploop_fluid.run  # terrain without fluid
    fallback = FieldSampler(snap, "bilinear", fallback=field(level=3.0)[3])
    for models in ([FluidForces(fallback, outside="air", velocity_profile="uniform")], [FluidForces(2.5, outside="air", velocity_profile="uniform")],
                   [FluidForces(snap, outside="air", basset=True, velocity_profile="uniform")], [FluidForces(snap, outside="error", velocity_profile="uniform")],
                   [FluidForces(snap, outside="air", compiled=False, velocity_profile="uniform")]):
        assert steploop.runner(sim_with(models)) is None
    assert steploop.runner(sim_with(static_models=False)) is None
    assert steploop.runner(sim_with(integrator="report")) is None
    assert steploop.runner(sim_with(integrator="adaptive_free_flight")) is None
    two = [HeightField(x, y, bed, ROCK), HeightField(x, y, bed - 1.0, ROCK)]
    assert steploop.runner(sim_with(boundaries=two)) is None


CI_CLOSURE = (Path(__file__).resolve().parents[1] / "data" / "ci_closure.toml").read_text()


def _same_nc(a, b):
    import xarray as xr

    for group in (None, "convergence_history"):
        try:
            da, db = xr.open_dataset(a, group=group), xr.open_dataset(b, group=group)
        except OSError:  # no such group in this file
            continue
        with da, db:
            assert set(da.variables) == set(db.variables)
            for name in da.variables:
                np.testing.assert_array_equal(da[name].values, db[name].values, err_msg=f"{a.name}: {name}")
            assert {k: str(v) for k, v in da.attrs.items() if k != "history"} == \
                   {k: str(v) for k, v in db.attrs.items() if k != "history"}


@pytest.mark.parametrize("remap", ["porous", "raised_bed"])
def test_closure_run_files_are_identical_with_the_compiled_dem(remap, tmp_path, monkeypatch):
    """A closure run (default integrator and log velocity profile) with the compiled DEM loop writes the same
    cycle fields, restart records and trajectories as with the DEM stepped in Python."""
    text = scenario_with(CI_CLOSURE, {"closure.remap": remap})
    done = []
    monkeypatch.setattr(steploop_fluid, "run", _counting(steploop_fluid.run, done))
    ClosureRun(closure_setup(parse_scenario(text)), tmp_path / "new", text).run()
    assert sum(done) > 100
    monkeypatch.setattr(steploop, "runner", lambda sim: None)
    ClosureRun(closure_setup(parse_scenario(text)), tmp_path / "ref", text).run()
    files = sorted(p.name for p in (tmp_path / "ref").glob("*_000*"))
    assert any(f.startswith("restart") for f in files)
    assert sorted(p.name for p in (tmp_path / "new").glob("*_000*")) == files
    for name in files:
        a, b = tmp_path / "ref" / name, tmp_path / "new" / name
        if name.endswith(".npz"):
            da, db = np.load(a), np.load(b)
            assert da.files == db.files
            for k in da.files:
                np.testing.assert_array_equal(da[k], db[k], err_msg=f"{name}: {k}")
        else:
            _same_nc(a, b)
