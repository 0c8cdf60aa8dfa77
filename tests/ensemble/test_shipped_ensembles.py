"""The ensemble specs shipped in examples/ensembles/ load and give the members their README promises."""
from pathlib import Path

import pytest

from breachflow.ensemble.spec import load_spec

ROOT = Path(__file__).resolve().parents[2]


def test_typical_feasibility_is_27_closure_members_on_the_typical_breach():
    spec = load_spec(ROOT / "examples" / "ensembles" / "typical_feasibility.toml")
    assert spec.runner == "closure"
    assert spec.dims == ("flood_level", "mass_size", "batch") and spec.shape == (3, 3, 3)
    members = spec.members()
    assert len(members) == 27 and len({m.key for m in members}) == 27
    seen = set()
    for m in members:
        table = spec.member_table(m)
        assert table["site"]["preset"] == "typical_breach"  # from the base scenario file
        assert table["hydro"]["resolution"] == "4 m"
        # the varied values land in the member's scenario, the rest comes from the base file
        assert table["site"]["flood_water_elevation"] == m.values["flood_level"]
        assert table["placement"]["diameter"] == m.values["mass_size"]
        assert table["placement"]["batch"] == m.values["batch"]
        assert table["placement"]["density"] == "2650 kg/m^3"
        seen.add((m.values_si["flood_level"], m.values_si["mass_size"], m.values_si["batch"]))
    assert len(seen) == 27
    assert sorted({s[0] for s in seen}) == pytest.approx([35.1, 36.6, 38.1])
