"""Which shipped scenarios still use the keys the closure in time replaces: the free ``[placement] rate`` (the
operation time now follows from a ``[closure] method``) and the fixed ``[criteria] seepage_fraction`` (now the
``polder_leakage`` criterion). The list below may only shrink: a new scenario with either key fails, and so
does a listed file that no longer has it (take it off the list). Both keys are deprecated: reading them warns,
naming the file, the line, the key and what replaces it."""
import re
import tomllib
import warnings
from pathlib import Path

import pytest

from breachflow.scenario.config import load_scenario

ROOT = Path(__file__).resolve().parents[2]

#: shipped files still on a replaced key, and which
STILL_ON_REPLACED_KEYS: dict = {}


def _keys_in_toml(path: Path) -> set:
    data = tomllib.loads(path.read_text())
    found = set()
    if "rate" in data.get("placement", {}):
        found.add("rate")
    if "seepage_fraction" in data.get("criteria", {}):
        found.add("seepage_fraction")
    return found


def _keys_in_python(path: Path) -> set:
    """TOML text inside a pipeline: a ``rate = `` or ``seepage_fraction = `` line."""
    text = path.read_text()
    found = set()
    if re.search(r"(?m)^\s*rate\s*=", text):
        found.add("rate")
    if re.search(r"(?m)^\s*seepage_fraction\s*=", text):
        found.add("seepage_fraction")
    return found


def test_shipped_scenarios_use_replaced_keys_only_where_listed():
    found = {}
    for path in sorted([*ROOT.glob("examples/**/*.toml"), *ROOT.glob("src/breachflow/data/*.toml")]):
        keys = _keys_in_toml(path)
        if keys:
            found[path.relative_to(ROOT).as_posix()] = keys
    for path in sorted([*ROOT.glob("pipelines/*.py"), *ROOT.glob("examples/**/*.py")]):
        keys = _keys_in_python(path)
        if keys:
            found[path.relative_to(ROOT).as_posix()] = keys
    assert found == STILL_ON_REPLACED_KEYS


REPLACED = """[placement]
diameter = "1 m"
rate = "30 1/hr"

[criteria]
mode = "all"
overflow_discharge = "0.5 m^3/s"
seepage_fraction = 0.3
"""


def test_replaced_keys_warn_naming_file_line_key_and_replacement(tmp_path):
    path = tmp_path / "old.toml"
    path.write_text(REPLACED)
    with pytest.warns(DeprecationWarning) as rec:
        sc = load_scenario(path)
    msgs = [str(w.message) for w in rec if issubclass(w.category, DeprecationWarning)]
    rate = next(m for m in msgs if "[placement] rate" in m)
    assert rate.startswith(f"{path}, line 3: ") and "[closure] method" in rate and "t/h" in rate
    frac = next(m for m in msgs if "[criteria] seepage_fraction" in m)
    assert frac.startswith(f"{path}, line 8: ") and "polder_leakage" in frac and "[polder]" in frac
    # still read as before
    assert sc["placement"].plan.rate == pytest.approx(30 / 3600)
    assert "seepage_fraction" in [c.name for c in sc["criteria"].criteria.items]
    # the replacements: no warning
    new = REPLACED.replace('rate = "30 1/hr"\n', "").replace("seepage_fraction = 0.3", 'polder_leakage = "1 cm/day"')
    path.write_text(new + '[closure]\nmethod = "barge_crane"\n[polder]\narea = "100 ha"\n')
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        load_scenario(path)


def test_a_listed_shipped_scenario_warns_for_each_replaced_key():
    for name in sorted(n for n in STILL_ON_REPLACED_KEYS if n.endswith(".toml")):  # (none left)
        path = ROOT / name
        with pytest.warns(DeprecationWarning) as rec:
            load_scenario(path)
        text = " ".join(str(w.message) for w in rec)
        for key in STILL_ON_REPLACED_KEYS[name]:
            section = "placement" if key == "rate" else "criteria"
            line = next(i for i, ln in enumerate(path.read_text().splitlines(), 1) if re.match(rf"\s*{key}\s*=", ln))
            assert f"{path}, line {line}: [{section}] {key}: deprecated" in text, text


@pytest.mark.parametrize("name", ["examples/ensembles/typical_feasibility.toml",
                                  "examples/ensembles/typical_replicates.toml"])
def test_the_typical_breach_ensembles_are_read_without_a_deprecation_warning(name):
    """The last two shipped files on ``seepage_fraction`` are judged by ``polder_leakage`` with a seal now."""
    path = ROOT / name
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        sc = load_scenario(path)
    names = [c.name for c in sc["criteria"].criteria.items]
    assert "polder_leakage" in names and "seepage_fraction" not in names
