"""Ensemble specs, member seeds, the TOML writer, result normalisation and members run in-process."""
import json
import tomllib

import numpy as np
import pytest

from breachflow.errors import InputError, ParseError, UnitError
from breachflow.ensemble import build_dataset, execute_member, member_seed, parse_spec, plan, validate_result
from breachflow.ensemble.runners import normalise_results
from breachflow.ensemble.spec import dump_toml
from breachflow.units import Q_

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


def spec_text(vary: str, extra: str = "") -> str:
    return f'[ensemble]\nname = "t"\nrunner = "closure_window"\n{extra}\n[ensemble.vary]\n{vary}\n{BASE}'


def test_factorial_dims_coordinates_and_si_values():
    spec = parse_spec(spec_text('"breach.length" = ["20 m", "98.425 ft"]\npolder.area = ["400 ha", "2 km^2", "800 ha"]\n'
                                'mass = { parameter = "placement.mass_size", values = ["1 m", "150 cm"] }'))
    assert spec.dims == ("breach_length", "polder_area", "mass")
    assert spec.shape == (2, 3, 2)
    values, unit = spec.parameters[1].si
    assert unit == "m^2"
    np.testing.assert_allclose(values, [4e6, 2e6, 8e6])
    np.testing.assert_allclose(spec.parameters[0].si[0], [20.0, 98.425 * 0.3048])
    members = spec.members()
    assert len(members) == 12
    assert members[0].index == (0, 0, 0) and members[-1].index == (1, 2, 1)  # C order
    table = spec.member_table(members[5])
    assert table["polder"]["area"] == members[5].values["polder_area"]
    assert table["placement"]["mass_size"] == members[5].values["mass"]
    assert table["flood"]["surge_height"] == "2.8 m"   # base untouched


def test_explicit_members_design():
    text = ('[ensemble]\nrunner = "closure_window"\n[[ensemble.members]]\n"breach.length" = "20 m"\n"polder.area" = "400 ha"\n'
            '[[ensemble.members]]\n"breach.length" = "40 m"\n"polder.area" = "1000 ha"\n' + BASE)
    spec = parse_spec(text)
    assert spec.design == "members" and spec.dims == ("member",) and spec.shape == (2,)
    assert [m.values["breach_length"] for m in spec.members()] == ["20 m", "40 m"]


@pytest.mark.parametrize("vary, message", [
    ('"breach.length" = ["20 m", "3 kg"]', "different dimensions"),
    ('"breach.length" = ["20 m", "2000 cm"]', "repeated value"),
    ('"breach.length" = []', "non-empty"),
    ('length = ["20 m"]', "dotted path"),
    ('"breach.length" = ["20 zorgs"]', "cannot read"),
])
def test_bad_vary_tables_name_the_parameter(vary, message):
    with pytest.raises((ParseError, UnitError), match=message):
        parse_spec(spec_text(vary), path="spec.toml")


def test_unknown_ensemble_key_names_file_and_line():
    with pytest.raises(ParseError) as info:
        parse_spec('[ensemble]\nrunner = "closure_window"\nworkerz = 2\n[ensemble.vary]\n"breach.length" = ["1 m"]\n' + BASE,
                   path="spec.toml")
    assert info.value.path == "spec.toml" and info.value.line == 3


def test_base_scenario_from_file_with_inline_override(tmp_path):
    (tmp_path / "site.toml").write_text(BASE)
    (tmp_path / "spec.toml").write_text('[ensemble]\nbase = "site.toml"\n[ensemble.vary]\n"breach.length" = ["20 m"]\n'
                                         '[polder]\ninundation_depth = "50 cm"\n')
    from breachflow.ensemble import load_spec

    spec = load_spec(tmp_path / "spec.toml")
    assert spec.base["polder"] == {"area": "800 ha", "inundation_depth": "50 cm"}
    assert spec.base["flood"]["fall_rate"] == "40 cm/hr"


def test_member_seed_depends_only_on_the_member_values():
    a = parse_spec(spec_text('"breach.length" = ["20 m", "30 m"]\npolder.area = ["400 ha", "800 ha"]'))
    b = parse_spec(spec_text('polder.area = ["8 km^2", "400 ha", "1200 ha"]\n"breach.length" = ["3000 cm", "20 m"]'))
    seeds_a = {(m.values_si["breach_length"], m.values_si["polder_area"]): m.seed for m in a.members()}
    seeds_b = {(m.values_si["breach_length"], m.values_si["polder_area"]): m.seed for m in b.members()}
    common = set(seeds_a) & set(seeds_b)
    assert len(common) == 4   # same physical values, other order, other units, other grid
    assert all(seeds_a[k] == seeds_b[k] for k in common)
    assert len(set(seeds_a.values())) == 4
    assert member_seed({"x": 1.0}, 0) != member_seed({"x": 1.0}, 1)
    assert 0 <= member_seed({"x": 1.0}) < 2**63


def test_toml_writer_round_trips():
    data = {"flood": {"surge_height": "2.8 m", "n": 3, "x": 0.1, "flag": True, "names": ["a", "b"],
                      "weird key": 'q"uote'},
            "dem": {"material": {"density": "2650 kg/m^3"}, "list": [1.5, 2.5]}}
    assert tomllib.loads(dump_toml(data)) == data
    # a subset of sections written first is a prefix of the whole text (parse-error line numbers stay right)
    assert dump_toml(data, ["dem", "flood"]).startswith(dump_toml(data, ["dem"]))


def test_result_normalisation_converts_to_si_and_keeps_kinds():
    out = normalise_results({"t": Q_(2.0, "h"), "q": (7060, "cfs"), "n": 3, "ok": True, "s": "balance",
                             "d": np.float64(0.5)}, {"d": {"units": "m"}})
    assert out["t"].value == pytest.approx(7200.0) and out["t"].units == "s"
    assert out["q"].value == pytest.approx(7060 * 0.3048**3) and out["q"].units == "m^3/s"
    assert (out["n"].kind, out["ok"].kind, out["s"].kind) == ("int", "bool", "str")
    assert out["d"].units == "m" and out["d"].value == 0.5
    with pytest.raises(InputError, match="scalar"):
        normalise_results({"a": Q_(np.ones(3), "m")}, {})
    with pytest.raises(InputError, match="declared"):
        normalise_results({"a": Q_(1.0, "kg")}, {"a": {"units": "m"}})


def test_window_members_in_process_match_the_linear_closure_window(tmp_path):
    """docs/theory.md, *Closure window* with the breach at the crest: Q_D = h_W B v, r_P = Q_D / A_P, t_Q = h_W / (r_f + r_P),
    t_I = d_I / r_P, t_B = min(t_Q, t_I)."""
    spec, out_dir, members, tasks = plan(
        parse_spec(spec_text('"breach.length" = ["20 m", "60 m"]\npolder.area = ["300 ha", "2000 ha"]')), out=tmp_path)
    records = [execute_member(t) for t in tasks]
    assert all(r["status"] == "ok" for r in records), [r.get("error_message") for r in records]
    ds = validate_result(build_dataset(spec, records, tasks[0].runner_cls, out_dir=out_dir))
    h, rf, v, d = 2.8, 0.4 / 3600, 3.0, 0.9
    B = ds["breach_length"].values[:, None]
    A = ds["polder_area"].values[None, :]
    rp = h * B * v / A
    tq, ti = h / (rf + rp), d / rp
    np.testing.assert_allclose(ds["closure_window"].values, np.minimum(tq, ti), rtol=1e-9)
    np.testing.assert_allclose(ds["balance_time"].values, tq, rtol=1e-9)
    np.testing.assert_allclose(ds["governing"].values, np.where(tq <= ti, 0, 1))
    assert ds["closure_window"].attrs["units"] == "s" and ds["polder_area"].attrs["units"] == "m^2"
    assert ds["polder_area"].attrs["display_units"] == "ha"
    rec = json.loads((out_dir / "members" / members[0].key / "result.json").read_text())
    assert rec["status"] == "ok" and rec["results"]["closure_window"]["units"] == "s"
    assert (out_dir / "members" / members[0].key / "scenario.toml").exists()


def test_member_that_is_not_a_single_scenario_fails_clearly(tmp_path):
    spec, _, _, tasks = plan(parse_spec(spec_text('"breach.length" = ["20 m"]').replace(
        'area = "800 ha"', 'area = ["800 ha", "900 ha"]')), out=tmp_path)
    rec = execute_member(tasks[0])
    assert rec["status"] == "failed" and rec["error_type"] == "InputError"
    assert "single scenario" in rec["error_message"]


def test_recorded_spec_reproduces_the_same_members():
    spec = parse_spec(spec_text('"breach.length" = ["20 m", "30 m"]\nmass = { parameter = "placement.mass_size", '
                                'values = ["1 m", "2 m"], long_name = "mass diameter" }', extra="seed = 7"))
    again = parse_spec(spec.to_toml())
    assert [(m.key, m.seed, m.values) for m in again.members()] == [(m.key, m.seed, m.values) for m in spec.members()]
    assert again.parameters[1].long_name == "mass diameter"


def test_unknown_runner_and_bad_options_fail_before_any_member_runs(tmp_path):
    with pytest.raises(InputError, match="available: .*window"):
        plan(parse_spec(spec_text('"breach.length" = ["20 m"]').replace('runner = "closure_window"', 'runner = "nope"')),
             out=tmp_path)
    with pytest.raises(InputError, match="options"):
        plan(parse_spec(spec_text('"breach.length" = ["20 m"]', extra="options = { steps = 3 }")), out=tmp_path)
    assert not (tmp_path / "members").exists()


def test_a_spec_file_is_also_a_scenario_file(tmp_path):
    from breachflow.scenario import load_scenario

    path = tmp_path / "spec.toml"
    path.write_text(spec_text('"breach.length" = ["20 m", "30 m"]'))
    scenario = load_scenario(path)
    assert scenario["ensemble"].table["runner"] == "closure_window"
    assert scenario["polder"].area == pytest.approx(8e6)
    assert scenario["ensemble"].spec(scenario).shape == (2,)
    path.write_text(spec_text('"breach.length" = ["20 m"]', extra="runnr = 'window'"))
    with pytest.raises(ParseError, match="runnr"):
        load_scenario(path)


def test_categorical_parameter_words_become_a_string_coordinate(tmp_path):
    from breachflow.scenario import closure_window

    text = spec_text('"flood.preset" = ["model_riverine", "katrina_2005"]\n"breach.length" = ["25 m"]').replace(
        'surge_height = "2.8 m"\nfall_rate = "40 cm/hr"', "")
    spec, out_dir, _, tasks = plan(parse_spec(text), out=tmp_path)
    records = [execute_member(t) for t in tasks]
    ds = validate_result(build_dataset(spec, records, tasks[0].runner_cls, out_dir=out_dir))
    assert list(ds["flood_preset"].values) == ["model_riverine", "katrina_2005"]
    assert "units" not in ds["flood_preset"].attrs
    from breachflow.ensemble import open_result, write_result

    back = open_result(write_result(ds, tmp_path / "presets.nc"))
    assert list(back["flood_preset"].values) == ["model_riverine", "katrina_2005"]
    for name in ds["flood_preset"].values:
        direct = closure_window(preset=str(name), breach_length="25 m", mean_velocity="3 m/s", polder_area="800 ha",
                                inundation_depth="90 cm")
        assert float(ds["closure_window"].sel(flood_preset=name, breach_length=25.0)) == pytest.approx(
            float(direct["closure_window"]), rel=1e-12)


def test_repeated_explicit_member_is_an_error():
    text = ('[ensemble]\n[[ensemble.members]]\n"breach.length" = "20 m"\n[[ensemble.members]]\n"breach.length" = "0.02 km"\n'
            + BASE)
    with pytest.raises(ParseError, match="member 1 repeats member 0"):
        parse_spec(text)
