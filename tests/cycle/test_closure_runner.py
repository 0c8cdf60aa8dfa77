"""The `closure` ensemble member runner, in-process on two cheap members."""
import numpy as np

from breachflow.ensemble import build_dataset, execute_member, parse_spec, plan, validate_result

from .._scenes import TINY_CLOSURE_MEMBER

SPEC = """
[ensemble]
name = "closure pair"
runner = "closure"
[ensemble.vary]
"placement.diameter" = ["1.6 m", "2.0 m"]
""" + TINY_CLOSURE_MEMBER


def test_closure_members_reduce_to_labelled_results(tmp_path):
    spec, out_dir, members, tasks = plan(parse_spec(SPEC), out=tmp_path)
    records = [execute_member(t) for t in tasks]
    assert all(r["status"] == "ok" for r in records), [r.get("error_message") for r in records]
    ds = validate_result(build_dataset(spec, records, tasks[0].runner_cls, out_dir=out_dir))
    np.testing.assert_allclose(ds["placement_diameter"].values, [1.6, 2.0])
    np.testing.assert_array_equal(ds["masses_placed"].values.ravel(), [6, 6])
    assert ds["closure_duration"].attrs["units"] == "s"
    # 6 masses at the default rate of 20 per hour
    np.testing.assert_allclose(ds["closure_duration"].values.ravel(), 6 / 20 * 3600)
    # bigger masses weigh more: tonnage grows with the diameter
    t = ds["tonnage"].values.ravel()
    assert t[1] > t[0] > 0
    q0 = ds["initial_breach_discharge"].values.ravel()
    q1 = ds["final_breach_discharge"].values.ravel()
    assert np.all(q1 < q0)
    # docs/theory.md, *Closure window*: Q_D = h_W B 3 m/s, r_P = Q_D / A_P, t_B = min(h_W / (r_fall + r_P), d_I / r_P)
    r_p = 3.0 * 12.0 * 3.0 / 1.0e6
    t_b = min(3.0 / (0.3 / 3600 + r_p), 1.5 / r_p)
    np.testing.assert_allclose(ds["closure_window"].values.ravel(), t_b, rtol=1e-9)
    achieved = ds["closure_achieved"].values.ravel().astype(bool)
    expected = achieved & (ds["closure_duration"].values.ravel() <= t_b)
    np.testing.assert_array_equal(ds["feasible"].values.ravel().astype(bool), expected)
