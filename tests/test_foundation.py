"""Units boundary, registries and the schema validator."""
import numpy as np
import pint
import pytest
import xarray as xr

from breachflow import InputError, UnitError, ureg
from breachflow.registry import Registry
from breachflow.schemas import validate
from breachflow.errors import SchemaError, ParseError
from breachflow.units import to_si


@pytest.mark.parametrize(
    "text, kind, expected",
    [
        ("2.8 m", "length", 2.8),
        ("9.2 ft", "length", 9.2 * 0.3048),
        ("40 cm/hr", "rate", 0.4 / 3600),
        ("800 ha", "area", 8.0e6),
        ("7060 cfs", "discharge", 7060 * 0.3048**3),
        ("2 acre", "area", 2 * 43560 * (1200 / 3937) ** 2),  # pint: US survey acre
        ("1.5 h", "time", 5400.0),
    ],
)
def test_strings_with_units_convert_to_si(text, kind, expected):
    assert to_si(text, name="x", kind=kind) == pytest.approx(expected, rel=1e-12)


def test_quantity_and_dataarray_inputs():
    assert to_si(ureg.Quantity(3, "ft"), name="h", kind="length") == pytest.approx(0.9144)
    # a Quantity of another registry is accepted too
    other = pint.UnitRegistry()
    assert to_si(other.Quantity(1, "km"), name="h", kind="length") == pytest.approx(1000.0)
    da = xr.DataArray([1.0, 2.0], dims="surge", attrs={"units": "ft", "long_name": "surge"})
    out = to_si(da, name="surge", kind="length")
    assert isinstance(out, xr.DataArray) and out.attrs["units"] == "m"
    np.testing.assert_allclose(out.values, [0.3048, 0.6096])
    assert out.attrs["long_name"] == "surge"


def test_wrong_dimension_names_parameter_unit_and_expected_dimension():
    with pytest.raises(UnitError) as err:
        to_si("3 m/s", name="polder_area", kind="area")
    msg = str(err.value)
    assert "polder_area" in msg and "m / s" in msg and "[length] ** 2" in msg


def test_bare_number_needs_a_default_unit():
    with pytest.raises(UnitError, match="surge_height"):
        to_si(2.0, name="surge_height", kind="length")
    assert to_si(2.0, name="surge_height", kind="length", default_unit="m") == 2.0
    assert to_si("2", name="surge_height", kind="length", default_unit="ft") == pytest.approx(0.6096)


def test_checks_for_nan_and_sign():
    with pytest.raises(InputError, match="not finite"):
        to_si("nan m", name="h", kind="length")
    with pytest.raises(InputError, match="> 0"):
        to_si("-1 ha", name="polder_area", kind="area", positive=True)
    with pytest.raises(UnitError, match="cannot read"):
        to_si("3 furlongsx", name="h", kind="length")


def test_registry_lookup_and_errors():
    reg = Registry("widget", "breachflow.test_widgets")

    @reg.register("Alpha")
    class Alpha:
        pass

    assert reg.get("alpha") is Alpha and "ALPHA" in reg
    with pytest.raises(InputError, match="unknown widget 'beta'; available: alpha"):
        reg.get("beta")
    with pytest.raises(InputError, match="already registered"):
        reg.register("alpha", object())


def test_schema_validator_reports_every_problem():
    schema = {
        "name": "t",
        "global_attributes": {"Conventions": {"pattern": r"CF-1\.\d+"}},
        "variables": {
            "depth": {"dims": [["x"]], "units": "m", "dtype": "floating", "min": 0,
                      "attributes": {"standard_name": None}},
            "speed": {"dims": [["x"]], "units": "m s-1"},
        },
    }
    good = xr.Dataset(
        {"depth": ("x", [0.0, 1.0], {"units": "m", "standard_name": "depth"}),
         "speed": ("x", [0.0, 1.0], {"units": "m s-1"})},
        attrs={"Conventions": "CF-1.10"},
    )
    assert validate(good, schema) is good
    bad = good.drop_vars("speed")
    bad["depth"] = ("x", [-1.0, 1.0], {"units": "ft"})
    bad.attrs = {}
    with pytest.raises(SchemaError) as err:
        validate(bad, schema, source="f.nc")
    msg = str(err.value)
    for part in ("f.nc", "Conventions", "units 'ft'", "minimum -1", "standard_name", "speed: missing"):
        assert part in msg


def test_parse_error_names_file_and_line():
    e = ParseError("bad", path="a.dat", line=3)
    assert str(e) == "a.dat:3: bad" and e.line == 3


@pytest.mark.parametrize("text, kind, expected", [
    ("1 m3/s", "discharge", 1.0), ("2 m s-1", "speed", 2.0), ("3 m2", "area", 3.0),
    ("1e-3 m", "length", 1e-3), ("-2.5e+1 m", "length", -25.0), ("7060 ft3/s", "discharge", 7060 * 0.3048**3),
])
def test_udunits_style_exponents(text, kind, expected):
    assert to_si(text, name="q", kind=kind) == pytest.approx(expected)


def test_dataarray_with_cf_units():
    da = xr.DataArray([1.0], dims="i", attrs={"units": "m s-1"})
    assert float(to_si(da, name="u", kind="speed")[0]) == 1.0


def test_unitless_string_says_no_unit():
    with pytest.raises(UnitError, match=r"surge_height: '2.8' has no unit; give one, e.g. '2.8 m' \(\[length\] expected\)"):
        to_si("2.8", name="surge_height", kind="length")


def test_schema_string_dtype_accepts_numpy_and_object_strings():
    spec = {"name": "s", "variables": {"a": {"dtype": "str"}}}
    validate(xr.Dataset({"a": ("x", np.array(["p", "q"]))}), spec)
    validate(xr.Dataset({"a": ("x", np.array(["p", "q"], dtype=object))}), spec)
    with pytest.raises(SchemaError, match="dtype float64 is not str"):
        validate(xr.Dataset({"a": ("x", np.array([1.0]))}), spec)
