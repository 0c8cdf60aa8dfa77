"""Which shipped scenarios still use the keys the closure in time replaces: the free ``[placement] rate`` (the
operation time now follows from a ``[closure] method``) and the fixed ``[criteria] seepage_fraction`` (now the
``polder_leakage`` criterion). The list below may only shrink: a new scenario with either key fails, and so
does a listed file that no longer has it (take it off the list)."""
import re
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

#: shipped files still on a replaced key, and which
STILL_ON_REPLACED_KEYS = {
    "src/breachflow/data/closure_default.toml": {"rate", "seepage_fraction"},
    "examples/district/closure.toml": {"rate", "seepage_fraction"},
    "examples/ensembles/typical_feasibility.toml": {"rate", "seepage_fraction"},
    "examples/ensembles/typical_replicates.toml": {"rate", "seepage_fraction"},
    "pipelines/closure_feasibility.py": {"rate"},
}


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
