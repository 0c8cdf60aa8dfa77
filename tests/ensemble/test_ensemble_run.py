"""Ensembles on a real dask LocalCluster (2 worker processes, shared by the module's tests)."""
import json
import logging
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from breachflow.errors import InputError
from breachflow.ensemble import member_runners, open_result, run, validate_result

distributed = pytest.importorskip("distributed")

BASE = """
[flood]
surge_height = "2.8 m"
fall_rate = "40 cm/hr"
[polder]
area = "800 ha"
inundation_depth = "90 cm"
[breach]
length = "30 m"
mean_velocity = "3 m/s"
"""


@pytest.fixture(scope="module")
def client():
    import dask

    # as breachflow's own local cluster: one member per worker at a time (a member that kills its worker
    # takes no queued member with it); a task whose worker died is not retried (the crash test stays short)
    with dask.config.set({"distributed.scheduler.worker-saturation": 1.0, "distributed.scheduler.allowed-failures": 0}):
        cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0",
                                           silence_logs=logging.CRITICAL)
    c = distributed.Client(cluster)
    yield c
    c.close()
    cluster.close()


class StandInClosureRunner:
    """A test-only runner registered by name, the way issue 7's "closure" runner will plug in: it reads
    a scenario section the closure_window runner ignores, uses its seed, and fails for one member."""

    sections = None
    outputs = {"tonnage": {"units": "kg", "dtype": "f8", "long_name": "mass placed"},
               "masses_placed": {"units": "1", "dtype": "i8", "long_name": "masses placed"},
               "closure_achieved": {"dtype": "bool", "long_name": "closure achieved"}}

    def run(self, member, run_dir, seed):
        table = member.table
        size = float(str(table["placement"]["mass_size"]).split()[0])
        if size > 2.5:
            raise RuntimeError(f"mass of {size} m does not fit the crane")
        rng = np.random.default_rng(seed)
        n = int(rng.integers(5, 50))
        (Path(run_dir) / "cycles.txt").write_text(f"{n}\n")
        density = 2650.0
        return {"tonnage": (n * density * np.pi / 6 * size**3, "kg"), "masses_placed": n,
                "closure_achieved": bool(n > 20)}


member_runners.register("closure_standin", StandInClosureRunner, overwrite=True)


class CrashingRunner:
    """Kills its worker process for one member (like a segfault in compiled code)."""

    sections = None
    outputs = {}

    def run(self, member, run_dir, seed):
        if member.values_si["x_value"] == 2.0:
            import os

            os._exit(3)
        return {"double": (2 * member.values_si["x_value"], "m")}


member_runners.register("crashing_test_runner", CrashingRunner, overwrite=True)


def write_spec(tmp_path, vary, runner="closure_window", extra=""):
    path = tmp_path / "spec.toml"
    path.write_text(f'[ensemble]\nname = "test"\nrunner = "{runner}"\n{extra}\n[ensemble.vary]\n{vary}\n{BASE}')
    return path


def test_window_ensemble_dims_coords_units_and_netcdf(client, tmp_path):
    spec = write_spec(tmp_path, '"breach.length" = ["20 m", "40 m"]\npolder.area = ["400 ha", "1200 ha"]\n'
                                'mass_size = { parameter = "placement.mass_size", values = ["1 m", "2 m"] }')
    ds = run(spec, client=client, progress=False)
    assert ds.sizes == {"breach_length": 2, "polder_area": 2, "mass_size": 2}
    assert ds["closure_window"].dims == ("breach_length", "polder_area", "mass_size")
    np.testing.assert_allclose(ds["polder_area"], [4e6, 12e6])
    assert ds["polder_area"].attrs["units"] == "m^2" and ds["breach_length"].attrs["units"] == "m"
    assert ds["polder_area"].attrs["scenario_parameter"] == "polder.area"
    assert ds["closure_window"].attrs["units"] == "s" and ds["breach_discharge"].attrs["units"] == "m^3/s"
    assert (ds["member_status"] == 0).all()
    # independent reference (docs/theory.md, *Closure window*, breach at the crest)
    h, rf, v, d = 2.8, 0.4 / 3600, 3.0, 0.9
    rp = h * ds["breach_length"] * v / ds["polder_area"]
    expected = np.minimum(h / (rf + rp), d / rp)
    xr.testing.assert_allclose(ds["closure_window"].isel(mass_size=0).drop_vars("mass_size"),
                               expected.transpose("breach_length", "polder_area").rename("closure_window"),
                               rtol=1e-9)
    # the window does not depend on the mass size
    np.testing.assert_array_equal(ds["closure_window"].isel(mass_size=0), ds["closure_window"].isel(mass_size=1))
    # the NetCDF on disk: schema-valid, units kept, same numbers
    back = open_result(tmp_path / "spec.ensemble" / "ensemble.nc")
    validate_result(back)
    assert back["closure_window"].attrs["units"] == "s"
    np.testing.assert_array_equal(back["closure_window"].values, ds["closure_window"].values)
    assert (back["governing"].values == ds["governing"].values).all()
    for rel in ds["member_run_dir"].values.ravel():
        assert json.loads((tmp_path / "spec.ensemble" / rel / "result.json").read_text())["status"] == "ok"


def test_failure_isolation(client, tmp_path):
    # a member with an impossible polder area fails inside the closure-window code; the others complete
    spec = write_spec(tmp_path, '"breach.length" = ["20 m", "40 m"]\npolder.area = ["-5 ha", "800 ha"]')
    ds = run(spec, client=client, progress=False)
    bad = ds.sel(polder_area=-5e4)
    good = ds.sel(polder_area=8e6)
    assert (bad["member_status"] == 1).all() and (good["member_status"] == 0).all()
    assert set(bad["member_error_type"].values) == {"ParseError"}
    assert all("area" in m and "> 0" in m for m in bad["member_error"].values)
    assert np.isnan(bad["closure_window"]).all() and np.isfinite(good["closure_window"]).all()
    assert ds.attrs["ensemble_failed"] == 2


def test_registered_runner_plugs_in_with_its_own_failures(client, tmp_path):
    spec = write_spec(tmp_path, 'mass_size = { parameter = "placement.mass_size", values = ["1 m", "2 m", "3 m"] }\n'
                                '"breach.length" = ["20 m", "40 m"]', runner="closure_standin")
    ds = run(spec, client=client, progress=False)
    assert set(ds.data_vars) >= {"tonnage", "masses_placed", "closure_achieved", "member_status"}
    assert ds["tonnage"].attrs["units"] == "kg"
    assert ds["closure_achieved"].attrs["flag_meanings"] == "false true"
    failed = ds["member_status"].sel(mass_size=3.0)
    assert (failed == 1).all() and (ds["member_status"].sel(mass_size=[1.0, 2.0]) == 0).all()
    assert "does not fit" in str(ds["member_error"].sel(mass_size=3.0).values[0])
    # the runner's results follow from its seed: re-derive them here
    for m in ds["masses_placed"].sel(mass_size=[1.0, 2.0]).stack(k=("mass_size", "breach_length")).k.values:
        sel = dict(zip(("mass_size", "breach_length"), m))
        n = int(np.random.default_rng(int(ds["member_seed"].sel(sel))).integers(5, 50))
        assert int(ds["masses_placed"].sel(sel)) == n
        assert float(ds["tonnage"].sel(sel)) == pytest.approx(n * 2650 * np.pi / 6 * sel["mass_size"] ** 3)
        rundir = tmp_path / "spec.ensemble" / str(ds["member_run_dir"].sel(sel).values)
        assert (rundir / "cycles.txt").read_text() == f"{n}\n"


def test_resume_skips_completed_members_and_reruns_the_rest(client, tmp_path):
    spec = write_spec(tmp_path, '"synthetic.steps" = [5, 10]\n"synthetic.size" = [8, 16]\n'
                                '"synthetic.fail" = [false, true]', runner="synthetic")
    first = run(spec, client=client, progress=False)
    assert (first["member_status"].sel(synthetic_fail=0) == 0).all()
    assert (first["member_status"].sel(synthetic_fail=1) == 1).all()
    out = tmp_path / "spec.ensemble"
    started = {p.parent.name: json.loads(p.read_text())["started"] for p in out.glob("members/*/result.json")}
    ok_dirs = [str(r) for r in first["member_run_dir"].sel(synthetic_fail=0).values.ravel()]
    (out / ok_dirs[0] / "result.json").unlink()               # lost: must be rerun
    second = run(spec, client=client, progress=False)
    after = {p.parent.name: json.loads(p.read_text())["started"] for p in out.glob("members/*/result.json")}
    rerun = {k for k in after if after[k] != started.get(k)}
    failed_keys = {Path(str(r)).name for r in first["member_run_dir"].sel(synthetic_fail=1).values.ravel()}
    assert rerun == {Path(ok_dirs[0]).name} | failed_keys      # the lost member and the failed ones
    for name in ("field_mean", "field_max", "steps", "smooth", "member_status", "member_seed"):
        np.testing.assert_array_equal(first[name].values, second[name].values)
    third = run(spec, client=client, progress=False, retry_failed=False)
    final = {p.parent.name: json.loads(p.read_text())["started"] for p in out.glob("members/*/result.json")}
    assert final == after                                       # nothing rerun at all
    np.testing.assert_array_equal(third["field_mean"].values, second["field_mean"].values)


def test_identical_results_with_one_and_two_workers(client, tmp_path):
    vary = '"synthetic.steps" = [3, 7]\n"synthetic.size" = [12, 20]\n"synthetic.amplitude" = ["1 m", "50 cm"]'
    spec = write_spec(tmp_path, vary, runner="synthetic")
    one = run(spec, client=client, workers=1, out=tmp_path / "one", progress=False)
    two = run(spec, client=client, workers=2, out=tmp_path / "two", progress=False)
    used = [{json.loads(p.read_text())["worker"] for p in (tmp_path / d).glob("members/*/result.json")}
            for d in ("one", "two")]
    assert len(used[0]) == 1 and len(used[1]) == 2
    for name in ("field_mean", "field_max", "field_rms_amplitude", "steps", "smooth", "label", "member_seed"):
        np.testing.assert_array_equal(one[name].values, two[name].values)
    # the workload really depends on the seed: members differ from each other
    assert len(np.unique(one["field_mean"].values)) == one["field_mean"].size
    # independent reference of the synthetic workload (Jacobi sweeps of the 5-point Laplacian, k = 0.2,
    # fixed boundary) from each member's seed; the amplitude was given in m and cm
    for sel in ({"synthetic_steps": 3, "synthetic_size": 12, "synthetic_amplitude": 0.5},
                {"synthetic_steps": 7, "synthetic_size": 20, "synthetic_amplitude": 1.0}):
        m = one.sel(sel)
        u = np.random.default_rng(int(m["member_seed"])).random((sel["synthetic_size"],) * 2)
        for _ in range(sel["synthetic_steps"]):
            new = u.copy()
            new[1:-1, 1:-1] = u[1:-1, 1:-1] + 0.2 * (u[:-2, 1:-1] + u[2:, 1:-1] + u[1:-1, :-2] + u[1:-1, 2:]
                                                      - 4 * u[1:-1, 1:-1])
            u = new
        assert float(m["field_mean"]) == pytest.approx(u.mean(), rel=1e-12)
        assert float(m["field_rms_amplitude"]) == pytest.approx(sel["synthetic_amplitude"] * np.sqrt((u**2).mean()),
                                                                rel=1e-12)
    assert one["field_rms_amplitude"].attrs["units"] == "m"


def test_workers_beyond_the_cluster_are_an_error(client, tmp_path):
    spec = write_spec(tmp_path, '"synthetic.steps" = [1]', runner="synthetic")
    with pytest.raises(InputError, match="workers"):
        run(spec, client=client, workers=3, progress=False)


def test_cli_runs_on_an_existing_scheduler_by_address(client, tmp_path):
    from typer.testing import CliRunner

    from breachflow.cli import app

    spec = write_spec(tmp_path, '"breach.length" = ["20 m", "40 m"]\npolder.area = ["400 ha"]')
    res = CliRunner().invoke(app, ["ensemble", str(spec), "--scheduler", client.scheduler.address,
                                   "--out", str(tmp_path / "cli"), "--no-progress"])
    assert res.exit_code == 0, res.output
    assert "closure_window" in res.output and "2 of 2 members ok" in res.output
    ds = open_result(tmp_path / "cli" / "ensemble.nc")
    assert ds.sizes == {"breach_length": 2, "polder_area": 1}
    listed = CliRunner().invoke(app, ["ensemble", "--list-runners"])
    assert "window" in listed.output and "closure_standin" in listed.output


def test_invalid_result_is_not_written_and_an_old_file_survives(tmp_path):
    from breachflow.errors import SchemaError
    from breachflow.ensemble import write_result

    ds = xr.Dataset({"member_status": (("x",), np.zeros(2, dtype="i1"))}, coords={"x": [1.0, 2.0]},
                    attrs={"Conventions": "CF-1.10"})
    path = tmp_path / "ensemble.nc"
    path.write_bytes(b"previous result")
    with pytest.raises(SchemaError, match="member_error"):
        write_result(ds, path)
    assert path.read_bytes() == b"previous result" and list(tmp_path.iterdir()) == [path]


def test_closure_feasibility_pipeline_runs_closure_members(client, tmp_path, capsys):
    import importlib.util

    path = Path(__file__).resolve().parents[2] / "pipelines" / "closure_feasibility.py"
    spec = importlib.util.spec_from_file_location("closure_feasibility_pipeline", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    # real closure members: an 8 m breach closed with 2.5 m masses, into a small and a large polder, two
    # placement seeds (replicates) each
    assert mod.main([str(tmp_path), "--lengths", "8", "--areas", "20", "200", "--sizes", "2.5",
                     "--replicates", "2", "--scheduler", client.scheduler.address]) == 0
    ds = open_result(tmp_path / "ensemble.nc")
    # the ensemble dimensions, and the closure members' per-cycle figures along cycle (at most 8 cycles)
    assert {d: n for d, n in ds.sizes.items() if d != "cycle"} == {"breach_length": 1, "polder_area": 2, "mass_size": 1,
                                                                   "replicate": 2}
    assert ds.sizes["cycle"] == int(ds["cycles"].max())
    assert (ds["member_status"] == 0).all()
    assert ds["mass_size"].attrs["units"] == "m" and ds["mass_size"].values.tolist() == [2.5]
    # docs/theory.md, *Closure window* with the pipeline's base scenario: Q_D = h_W B 3 m/s, r_P = Q_D / A_P,
    # t_B = min(h_W / (r_fall + r_P), d_I / r_P)
    r_p = 3.0 * 8.0 * 3.0 / np.array([20e4, 200e4])
    t_b = np.minimum(3.0 / (0.3 / 3600 + r_p), 1.5 / r_p)
    np.testing.assert_allclose(ds["closure_window"].values.ravel(), np.repeat(t_b, 2), rtol=1e-9)
    # 6 masses per cycle, at most 8 cycles, delivered by a crane barge at 400 t/h (spheres of 2.5 m, 2650 kg/m3)
    cycles = ds["cycles"].values.ravel()
    assert np.all((cycles >= 1) & (cycles <= 8))
    np.testing.assert_array_equal(ds["masses_placed"].values.ravel(), 6 * cycles)
    # per cycle: 6 masses a cycle up to each member's last cycle, fill value after it
    per = ds["cycle_masses_placed"].values.reshape(-1, ds.sizes["cycle"])
    for row, n in zip(per, cycles):
        np.testing.assert_array_equal(row[:n], 6 * np.arange(1, n + 1))
    unit_t = np.pi / 6.0 * 2.5 ** 3 * 2650.0 / 1000.0
    np.testing.assert_allclose(ds["closure_duration"].values.ravel(), 6 * cycles * unit_t / 400.0 * 3600.0, rtol=1e-9)
    achieved = ds["closure_achieved"].values.ravel() == 1
    np.testing.assert_array_equal(ds["feasible"].values.ravel() == 1,
                                  achieved & (ds["closure_duration"].values.ravel() <= np.repeat(t_b, 2)))
    # common random numbers: the polder area enters only the window (the flood and polder held frozen in the
    # simulation), so with the same seeds the closure simulations are identical along polder_area
    for name in ("cycles", "tonnage", "final_breach_discharge"):
        v = ds[name].values
        np.testing.assert_array_equal(v[:, 0], v[:, 1], err_msg=name)
    # P(closure inside the window) over the replicates
    feas = ds["feasible"].values == 1
    np.testing.assert_allclose(ds["closure_probability"].values, feas.mean(axis=-1))
    assert np.all(ds["closure_probability_lower"].values <= ds["closure_probability"].values)
    # the placed masses cut the breach discharge; an impervious (raised-bed) pile has no seepage
    assert np.all(ds["final_breach_discharge"].values < ds["initial_breach_discharge"].values)
    assert np.all(ds["final_seepage_discharge"].values == 0.0)
    assert (tmp_path / "closure_feasibility.png").stat().st_size > 10_000
    out = capsys.readouterr().out
    assert "4 members in" in out and "P(closure inside the window) over 2 seeds" in out


def _worker_settings(dask_worker):
    import os

    import dask
    import numba

    return {"numba_threads": numba.config.NUMBA_NUM_THREADS, "env": os.environ.get("NUMBA_NUM_THREADS"),
            "omp": os.environ.get("OMP_NUM_THREADS"), "malloc_trim": os.environ.get("MALLOC_TRIM_THRESHOLD_"),
            "profile": dask.config.get("distributed.worker.profile.enabled"),
            "intervals": [dask.config.get(k) for k in ("distributed.admin.tick.interval",
                                                       "distributed.worker.memory.monitor-interval",
                                                       "distributed.admin.system-monitor.interval")],
            "callbacks": sorted(dask_worker.periodic_callbacks)}


def test_local_cluster_workers_have_one_compute_thread_and_no_profiler(monkeypatch):
    from breachflow.ensemble.execute import _quiet_distributed, local_cluster

    monkeypatch.delenv("NUMBA_NUM_THREADS", raising=False)
    cluster = local_cluster(1)
    c = distributed.Client(cluster)
    try:
        (settings,) = c.run(_worker_settings).values()
    finally:
        with _quiet_distributed():
            c.close()
            cluster.close()
    assert settings["numba_threads"] == 1 and settings["env"] == "1" and settings["omp"] == "1"
    assert settings["malloc_trim"] is None
    assert settings["profile"] is False and "profile" not in settings["callbacks"]
    assert settings["intervals"] == ["1s", "1s", "2s"]      # dask: 20ms, 100ms, 500ms
    # the client's process (which hosts the nanny) keeps its numba thread count
    import os

    assert "NUMBA_NUM_THREADS" not in os.environ


def test_a_member_that_kills_its_worker_is_recorded_and_the_others_complete(client, tmp_path):
    # 6 members > 2 x threads: dask queues them on the scheduler and (worker-saturation 1.0) hands each
    # worker one member at a time, so the member that kills its worker takes no other member with it
    values = [f"{v} m" for v in range(1, 7)]
    spec = {"ensemble": {"runner": "crashing_test_runner", "vary": {"x.value": values}}}
    ds = run(spec, client=client, out=tmp_path, progress=False)
    np.testing.assert_array_equal(ds["member_status"].values, [0, 1, 0, 0, 0, 0])
    assert ds["member_error_type"].values[1] == "KilledWorker"
    np.testing.assert_array_equal(ds["double"].values[[0, 2, 3, 4, 5]], [2.0, 6.0, 8.0, 10.0, 12.0])
    assert ds["double"].attrs["units"] == "m"
    rec = json.loads((tmp_path / str(ds["member_run_dir"].values[1]) / "result.json").read_text())
    assert rec["status"] == "failed" and rec["error_type"] == "KilledWorker"
    client.wait_for_workers(2, timeout=60)   # the nanny restarts the dead worker


# --- replicates: odds, not one dice roll ---------------------------------------------------------------
class BernoulliRunner:
    """Test runner: closes with probability ``x.p`` (a varied parameter) using the member's seed; its
    tonnage is a draw that does not depend on ``x.p`` (so common random numbers make it equal along x_p)."""

    sections = None
    outputs = {"tonnage": {"units": "kg", "dtype": "f8", "long_name": "mass placed"},
               "closure_duration": {"units": "s", "dtype": "f8", "long_name": "duration"},
               "feasible": {"dtype": "bool", "long_name": "closed inside the window"}}

    def run(self, member, run_dir, seed):
        rng = np.random.default_rng(seed)
        u, t, d = rng.random(), rng.uniform(100, 500), rng.uniform(1000, 5000)
        return {"feasible": bool(u < member.values_si["x_p"]), "tonnage": (t * 1000.0, "kg"),
                "closure_duration": (d, "s")}


member_runners.register("bernoulli_test_runner", BernoulliRunner, overwrite=True)


def test_replicate_spec_common_random_numbers():
    from breachflow.errors import ParseError
    from breachflow.ensemble import parse_spec

    spec = parse_spec('[ensemble]\nrunner = "closure_window"\nreplicates = 3\n[ensemble.vary]\n"polder.area" = ["1 ha", "2 ha"]\n'
                      + BASE)
    assert spec.dims == ("polder_area", "replicate") and spec.shape == (2, 3)
    ms = spec.members()
    assert [m.index for m in ms] == [(i, r) for i in range(2) for r in range(3)]
    seeds = np.array([m.seed for m in ms]).reshape(2, 3)
    np.testing.assert_array_equal(seeds[0], seeds[1])      # same seeds for every parameter value
    assert len(set(seeds[0])) == 3                          # different seeds across replicates
    assert len({m.key for m in ms}) == 6
    assert "replicates = 3" in spec.to_toml()
    for bad in ("0", "1.5", "true"):
        with pytest.raises(ParseError, match="replicates"):
            parse_spec(f'[ensemble]\nrunner = "closure_window"\nreplicates = {bad}\n[ensemble.vary]\n"polder.area" = ["1 ha"]\n'
                       + BASE)


def test_replicates_give_probabilities_with_wilson_intervals(client, tmp_path):
    from scipy.stats import binomtest

    spec = write_spec(tmp_path, '"x.p" = [0.2, 0.8]', runner="bernoulli_test_runner", extra="replicates = 40")
    ds = run(spec, client=client, progress=False)
    assert ds.sizes == {"x_p": 2, "replicate": 40}
    validate_result(ds)
    feas = ds["feasible"].values == 1
    k = feas.sum(axis=1)
    np.testing.assert_allclose(ds["closure_probability"].values, k / 40)
    for i in range(2):
        ci = binomtest(int(k[i]), 40).proportion_ci(method="wilson")
        assert ds["closure_probability_lower"].values[i] == pytest.approx(ci.low)
        assert ds["closure_probability_upper"].values[i] == pytest.approx(ci.high)
        # the interval holds the true probability (it does for these seeds; 95 % of seeds in general)
        assert ci.low <= [0.2, 0.8][i] <= ci.high
    # common random numbers: the tonnage draw does not depend on x_p, so it is equal along x_p
    np.testing.assert_array_equal(ds["tonnage"].values[0], ds["tonnage"].values[1])
    np.testing.assert_allclose(ds["tonnage_median"].values, np.median(ds["tonnage"].values, axis=1))
    np.testing.assert_allclose(ds["closure_duration_p10"].values, np.quantile(ds["closure_duration"].values, 0.1, axis=1))
    np.testing.assert_allclose(ds["closure_duration_p90"].values, np.quantile(ds["closure_duration"].values, 0.9, axis=1))
    assert ds["replicates_ok"].values.tolist() == [40, 40]
    for name in ("replicates_ok", "closure_probability", "tonnage_median"):
        assert "flag_meanings" not in ds[name].attrs and ds[name].attrs["ensemble_reduction"] == "replicate"
    # the CLI's summary shows the per-combination probabilities
    from rich.console import Console

    from breachflow.cli.ensemble import summary_table

    con = Console(record=True, width=160)
    con.print(summary_table(ds))
    text = con.export_text()
    assert "P(closure)" in text and f"{ds['closure_probability'].values[0]:.2f}" in text
    back = open_result(spec.parent / "spec.ensemble" / "ensemble.nc")
    np.testing.assert_allclose(back["closure_probability"].values, ds["closure_probability"].values)
    # feasible and closure_probability agree with a single draw per replicate: the same seeds as the
    # replicate seeds of the spec
    from breachflow.ensemble import load_spec

    seeds = {m.replicate: m.seed for m in load_spec(spec).members()}
    np.testing.assert_array_equal(ds["member_seed"].values[0], [seeds[r] for r in range(40)])


class StampingRunner:
    """Writes a NetCDF file through the package's provenance helper, as the closure runner's cycle files do."""

    sections = None
    outputs = {}

    def run(self, member, run_dir, seed):
        from breachflow.provenance import stamp

        stamp(xr.Dataset({"x": ((), 1.0)})).to_netcdf(Path(run_dir) / "member.nc")
        return {"one": (1.0, "m")}


member_runners.register("stamping_test_runner", StampingRunner, overwrite=True)


def test_member_files_record_the_ensemble_command_not_the_workers(client, tmp_path):
    from breachflow import provenance

    spec = write_spec(tmp_path, '"breach.length" = ["20 m", "40 m"]', runner="stamping_test_runner")
    provenance.set_command(["ensemble", str(spec), "--out", str(tmp_path / "o")])
    try:
        run(spec, out=tmp_path / "o", client=client, progress=False)
    finally:
        provenance.set_command(None)
    files = sorted((tmp_path / "o" / "members").glob("*/member.nc"))
    assert len(files) == 2
    want = f"breachflow ensemble {spec} --out {tmp_path / 'o'}"
    for f in files:
        with xr.open_dataset(f) as ds:
            assert ds.attrs["breachflow_command"] == want, f
            assert ds.attrs["history"].endswith(want)
        rec = json.loads((f.parent / "result.json").read_text())
        assert rec["command"] == want


CLOSURE_BASE = BASE + """
[placement]
diameter = "2.0 m"
batch = 2
"""


def test_closure_ensemble_refuses_impossible_members_before_anything_runs(tmp_path):
    path = tmp_path / "spec.toml"
    path.write_text('[ensemble]\nname = "t"\nrunner = "closure"\n[ensemble.vary]\n'
                    '"placement.density" = ["2650 kg/m^3", "900 kg/m^3", "1000 kg/m^3"]\n' + CLOSURE_BASE)
    out = tmp_path / "out"
    with pytest.raises(InputError) as err:
        run(path, out=out, progress=False)  # no client needed: nothing may start
    msg = str(err.value)
    assert "2 of 3 ensemble members cannot run" in msg
    assert "placement_density = 900" in msg and "placement_density = 1000" in msg
    assert "not heavier than water" in msg and "= 2650" not in msg
    assert not out.exists()


def test_member_checks_run_once_per_scenario_and_count_every_replicate(tmp_path):
    """Replicates differ only in their placement seed: the runner checks each distinct scenario once, and
    the warnings and refusals still count (and name) every member."""
    from breachflow.ensemble.execute import check_members, plan

    path = tmp_path / "spec.toml"
    path.write_text('[ensemble]\nname = "t"\nrunner = "closure"\nreplicates = 3\n[ensemble.vary]\n'
                    '"placement.density" = ["2650 kg/m^3", "900 kg/m^3"]\n' + CLOSURE_BASE)
    _, _, _, tasks = plan(path, tmp_path / "out")
    assert len(tasks) == 6
    calls = []

    class Counting(tasks[0].runner_cls):
        def check(self, member):
            calls.append(member.values["placement_density"])
            if member.values["placement_density"].startswith("900"):
                raise InputError("not heavier than water")
            return ["a warning"]

    for t in tasks:
        t.runner_cls = Counting
    with pytest.raises(InputError) as err:
        check_members(tasks)
    assert sorted(calls) == ["2650 kg/m^3", "900 kg/m^3"]
    assert "3 of 6 ensemble members cannot run" in str(err.value)
    calls.clear()
    ok = [t for t in tasks if t.scenario.values["placement_density"].startswith("2650")]
    assert check_members(ok) == ["a warning (3 of 3 members)"] and calls == ["2650 kg/m^3"]
