"""The README's Python snippets run as written, and the example notebook executes, on a short closure run and a
tiny ensemble made here (the coarse default scenario of the install warm-up, three cycles; two mass sizes ×
two placement seeds of a two-cycle closure)."""
import os
import re
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from breachflow.cycle.main import run_closure
from breachflow.warmup import warm_up_scenario

from ._scenes import TINY_CLOSURE_MEMBER

ROOT = Path(__file__).resolve().parents[1]

TINY_ENSEMBLE = """
[ensemble]
name = "tiny closure ensemble"
runner = "closure"
seed = 7
replicates = 2
[ensemble.vary]
mass_size = { parameter = "placement.diameter", values = ["1.6 m", "2.0 m"], long_name = "diameter of the dropped masses" }
""" + TINY_CLOSURE_MEMBER


def python_blocks(markdown: str) -> list[str]:
    """The fenced ```python blocks of a Markdown text."""
    return re.findall(r"^```python\n(.*?)^```", markdown, flags=re.S | re.M)


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """``runs/default`` (a short default run of 3 cycles) and ``runs/quick`` (a tiny ensemble) in a tmp dir."""
    base = tmp_path_factory.mktemp("readme")
    text = re.sub(r"max_cycles = \d+", "max_cycles = 3", warm_up_scenario())
    scenario = base / "short.toml"
    scenario.write_text(text)
    run_closure(scenario, base / "runs" / "default", plots=False)
    from dask.distributed import Client

    import breachflow.ensemble as ens

    with Client(processes=False, n_workers=1, threads_per_worker=1, dashboard_address=":0") as client:
        ens.run(TINY_ENSEMBLE, out=base / "runs" / "quick", client=client, progress=False)
    return base


def test_the_readme_has_python_snippets():
    blocks = python_blocks((ROOT / "README.md").read_text(encoding="utf-8"))
    assert blocks and any("open_mfdataset" in b for b in blocks)


def test_readme_python_snippets_run_as_written(runs, monkeypatch):
    monkeypatch.chdir(runs)
    ns: dict = {}
    for block in python_blocks((ROOT / "README.md").read_text(encoding="utf-8")):
        exec(compile(block, "README.md", "exec"), ns)  # noqa: S102 - the README's own code
    # what the snippet promises: the cycles stacked, quantities with units
    assert ns["ds"].sizes["cycle"] == 3
    assert str(ns["q"]["u"].data.units) == "meter / second"
    assert "time" in ns["tr"].coords and ns["tr"].sizes["trajectory"] == 5  # a CF trajectory per mass


def test_pint_quantify_needs_the_udunits_names_registered(runs):
    """Why the README imports breachflow first: pint alone cannot parse UDUNITS' "m s-1"; with the registry
    cf_xarray.units sets up (which breachflow imports) it can, and the value converts correctly."""
    import pint

    with pytest.raises(TypeError):  # pint reads "s-1" as s minus 1
        pint.UnitRegistry().parse_units("m s-1")
    import breachflow  # noqa: F401
    import pint_xarray  # noqa: F401

    ds = xr.open_dataset(runs / "runs" / "default" / "cycle_0001.nc")
    assert ds["u"].attrs["units"] == "m s-1"
    q = ds[["u"]].pint.quantify().pint.to({"u": "ft/s"})
    np.testing.assert_allclose(q["u"].pint.magnitude, ds["u"].values / 0.3048, equal_nan=True)


def test_the_example_notebook_executes(runs, monkeypatch):
    import nbclient
    import nbformat

    monkeypatch.delenv("MPLBACKEND", raising=False)  # the kernel's inline backend shows the plots
    monkeypatch.setenv("BREACHFLOW_RUN", str(runs / "runs" / "default"))
    monkeypatch.setenv("BREACHFLOW_ENSEMBLE", str(runs / "runs" / "quick"))
    nb = nbformat.read(ROOT / "examples" / "notebooks" / "results.ipynb", as_version=4)
    nbclient.NotebookClient(nb, timeout=300, kernel_name="python3",
                            resources={"metadata": {"path": str(ROOT / "examples" / "notebooks")}}).execute()
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])]
    assert not [o for o in outputs if o.get("output_type") == "error"]
    images = [o for o in outputs if "image/png" in o.get("data", {})]
    assert len(images) >= 3  # head, pile, P(closure)
