"""The energy bound on the closure scene: with ``remap = "raised_bed"`` the pile raises the bed to the tops
of its masses, leaving pits between them; no cell of a cycle's (steady) flow may carry more head than the
flood supplies, ``z + h + |u|^2 / 2g <= H``, or be faster than a fall from it, ``|u| <= sqrt(2 g (H - z))``
(``tests/swe/test_energy_bound.py`` for the solver's side)."""
import numpy as np
import pytest
import xarray as xr

from breachflow.cycle.main import default_scenario_text, run_closure

G = 9.81


def cycle_excess(path):
    """``(head excess (m) over the cells deeper than 1 cm, speed excess (m/s) over the wet cells)`` of a cycle
    file; ``H`` is the largest head on the three boundary rows of the flood side (the higher surface)."""
    with xr.open_dataset(path) as ds:
        z = ds.bed_elevation.values.squeeze()
        h = ds.depth.values.squeeze()
        sp = ds.speed.values.squeeze()
    wet = h > 1e-6
    head = np.where(wet, z + h + sp ** 2 / (2 * G), -np.inf)
    eta = np.where(wet, z + h, np.nan)
    rows = [0, 1, 2] if np.nanmean(eta[0]) > np.nanmean(eta[-1]) else [-1, -2, -3]
    H = max(float(head[r].max()) for r in rows)
    head_ex = float(np.max(np.where(h > 1e-2, head - H, -np.inf)))
    speed_ex = float(np.max(np.where(wet, sp - np.sqrt(2 * G * np.maximum(H - z, 0.0)), -np.inf)))
    return head_ex, speed_ex


@pytest.mark.slow
def test_raised_bed_closure_at_the_defaults_stays_below_the_upstream_head(tmp_path):
    """The default scenario with ``remap = "raised_bed"``, 4 cycles (about 2 min on a loaded 2-core box)."""
    text = default_scenario_text()
    assert 'remap = "porous"' in text and "max_cycles = 24" in text
    scen = tmp_path / "raised.toml"
    scen.write_text(text.replace('remap = "porous"', 'remap = "raised_bed"').replace("max_cycles = 24", "max_cycles = 4"))
    res = run_closure(scen, tmp_path / "run", plots=False)
    assert res.cycles == 4
    for g in range(1, res.cycles + 1):
        head_ex, speed_ex = cycle_excess(tmp_path / "run" / f"cycle_{g:04d}.nc")
        assert head_ex < 0.1 and speed_ex < 0.1, (g, head_ex, speed_ex)
