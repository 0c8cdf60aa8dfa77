""""window" is only the closure window: the nested model's box is ``[hydro] nested_box``, the local warm
re-solve ``[hydro] resolve = "region"``, the rest rule ``mean_speed``, the member runner ``closure_window``,
the default contact law ``step_averaged``. The former spellings still work, with a DeprecationWarning that
names the file, the key and the new spelling; giving both spellings is an error."""
import warnings

import pytest

from breachflow.cycle.rest import REST_RULES
from breachflow.dem import DemSimulation
from breachflow.dem.contact_law import contact_laws
from breachflow.ensemble.runners import member_runners
from breachflow.ensemble.spec import load_spec
from breachflow.errors import BreachflowError
from breachflow.scenario.config import load_scenario

BOX = '["-10 m", "10 m", "-8 m", "8 m"]'


def load(tmp_path, text):
    path = tmp_path / "site.toml"
    path.write_text(text)
    return path, load_scenario(path)


def test_hydro_window_is_nested_box_with_a_warning_naming_file_line_and_new_key(tmp_path):
    with pytest.warns(DeprecationWarning) as rec:
        path, sc = load(tmp_path, f'[hydro]\nresolution = "2 m"\nwindow = {BOX}\n')
    assert sc["hydro"].nested_box == (-10.0, 10.0, -8.0, 8.0)
    msg = str(rec[0].message)
    assert str(path) in msg and "line 3" in msg and "[hydro] window" in msg and "nested_box" in msg
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the new spelling: no warning
        assert load(tmp_path, f"[hydro]\nnested_box = {BOX}\n")[1]["hydro"].nested_box == (-10.0, 10.0, -8.0, 8.0)
    with pytest.raises(BreachflowError, match="nested_box"):
        load(tmp_path, f"[hydro]\nwindow = {BOX}\nnested_box = {BOX}\n")


def test_resolve_window_is_region(tmp_path):
    with pytest.warns(DeprecationWarning, match=r"site\.toml, line 2: \[hydro\] resolve = 'window' is deprecated; "
                                                r"write resolve = 'region'"):
        _, sc = load(tmp_path, '[hydro]\nresolve = "window"\n')
    assert sc["hydro"].resolve == "region"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert load(tmp_path, '[hydro]\nresolve = "region"\n')[1]["hydro"].resolve == "region"
    with pytest.raises(BreachflowError, match="resolve"):
        load(tmp_path, '[hydro]\nresolve = "windows"\n')


def test_rest_rule_window_is_mean_speed(tmp_path):
    with pytest.warns(DeprecationWarning, match=r"\[dem\] rest_rule = 'window' is deprecated; write rest_rule = 'mean_speed'"):
        _, sc = load(tmp_path, '[dem]\nrest_rule = "window"\n')
    assert sc["dem"].values["rest_rule"] == "mean_speed"
    assert REST_RULES.get("window") is REST_RULES.get("mean_speed") and REST_RULES.default == "mean_speed"


def test_member_runner_window_is_closure_window(tmp_path):
    path = tmp_path / "ens.toml"
    path.write_text('[ensemble]\nrunner = "window"\n[ensemble.vary]\n"breach.length" = ["20 m"]\n'
                    '[flood]\nsurge_height = "2.8 m"\nfall_rate = "40 cm/h"\n[polder]\narea = "800 ha"\n'
                    'inundation_depth = "90 cm"\n[breach]\nlength = "30 m"\nmean_velocity = "3 m/s"\n')
    with pytest.warns(DeprecationWarning) as rec:
        spec = load_spec(path)
    msg = str(rec[0].message)
    assert str(path) in msg and "line 2" in msg and "runner = 'closure_window'" in msg
    assert spec.runner == "closure_window"
    assert member_runners.get("window") is member_runners.get("closure_window")


def test_contact_law_window_averaged_is_an_alias_of_step_averaged():
    assert contact_laws.get("window_averaged") is contact_laws.get("step_averaged")
    assert contact_laws.default == "step_averaged"
    assert DemSimulation(contact_law="window_averaged").contact_law.code == DemSimulation().contact_law.code


def test_bench_closure_resolution_item_window_is_region():
    """``tasks.py bench closure --resolutions 4/window`` (the re-solve mode's former name) reads as ``4/region``."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[2] / "benchmarks" / "bench_closure.py"
    spec = importlib.util.spec_from_file_location("bench_closure_items", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)  # defines functions only; nothing runs
    with pytest.warns(DeprecationWarning, match=r"'4/window\+2': '/window' is deprecated; write '/region'"):
        assert mod.parse_item("4/window+2") == (4.0, "region", 2.0, "4 m/region+2 m")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert mod.parse_item("2/region") == (2.0, "region", None, "2 m/region")
        assert mod.parse_item("4/full") == (4.0, "full", None, "4 m/full")
    with pytest.raises(SystemExit, match="RES\\[/region\\|/full\\]"):
        mod.parse_item("4/windows")
