"""The detailed tier of a breach atlas: the closure simulation, with placement replicates, at the locations the
screening ranks worst.

For each chosen location the atlas writes one member of an ensemble (``breachflow ensemble``'s members design,
runner ``closure``): the district's terrain and levee as a ``[site]`` with the breach at the location's
chainage, of the screening's length, down to the protected-side ground; the masses of the screening's
design stone size unless the template sets ``[placement] diameter``; the closure window of the location
(head, open-breach discharge, the polder). The ensemble's replicates give P(closure) with its Wilson
interval and the tonnage and duration ranges; the atlas adds them to its layer (``p_closure``,
``p_closure_lower``/``_upper``, ``tonnage_detailed_t_median``, ...).

The ``[detailed]`` table of the district file::

    [detailed]
    worst = 5                    # the locations with the smallest margin (screening), or "all"
    replicates = 4               # placement seeds per location
    scenario = "closure.toml"    # a closure scenario template: [hydro], [dem], [placement], [criteria], [closure]
"""
from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import xarray as xr

from ..errors import InputError
from .config import District
from .locations import Location
from .screening import WALL_SLOPE

#: the template's sections the atlas fills in itself
OWN_SECTIONS = ("site", "flood", "polder", "breach", "ensemble")


def choose(ds: xr.Dataset, worst) -> list[int]:
    """Indices of the locations of the detailed tier: the *worst* at-risk locations by screening margin
    (smallest first; ``"all"``: every at-risk location)."""
    margin = np.where(np.isfinite(ds.margin_h.values), ds.margin_h.values, np.inf)
    at_risk = np.isfinite(ds.tonnage_t.values)
    order = [int(i) for i in np.argsort(margin, kind="stable") if at_risk[i]]
    if worst == "all":
        return order
    if not isinstance(worst, int) or isinstance(worst, bool) or worst < 1:
        raise InputError(f"[detailed] worst: expected a positive integer or \"all\", got {worst!r}")
    return order[:worst]


def longest_first(ds: xr.Dataset, chosen: list[int]) -> list[int]:
    """*chosen* in the order their members are handed to the workers: the largest screening tonnage first (a
    closure simulation lasts about as many cycles as its tonnage takes batches), so that the longest members
    start first and the short ones fill the gaps at the end instead of one long member running alone. The
    order changes no result: a member's seed depends on its replicate number only and its key on its values."""
    tonnage = np.nan_to_num(ds.tonnage_t.values[chosen], nan=0.0)
    return [chosen[k] for k in np.argsort(-tonnage, kind="stable")]


def ensemble_table(district: District, ds: xr.Dataset, locations: list[Location], chosen: list[int], *,
                   replicates: int, template: dict, seed: int = 2026) -> dict:
    """The ensemble spec (a TOML table) of the detailed tier."""
    for s in OWN_SECTIONS:
        if s in template:
            raise InputError(f"[detailed] scenario: the template must not set [{s}] (the atlas fills it from the "
                             f"district and the location)")
    # absolute paths: the members' scenarios live in their own directories, where a path relative to the
    # directory the atlas was started in would not resolve
    site = {"terrain": str(Path(district.terrain).resolve()), "levee": str(Path(district.levee).resolve()),
            "flood_level": f"{district.flood_level} m", "breach_wall_slope": WALL_SLOPE,  # the screening's breach
            "flood_side": district.flood_side, "manning_n": district.manning_n}
    if district.crs:
        site["crs"] = district.crs
    members = []
    for i in chosen:
        loc = locations[i]
        m = {"site.breach_at": f"{loc.chainage:.2f} m", "site.breach_length": f"{float(ds.breach_length_m[i]):.2f} m",
             "site.breach_bottom": f"{loc.protected_ground:.3f} m",
             "flood.surge_height": f"{float(ds.head_m[i]):.3f} m",
             # the window's Q_D = h_W B v is the screening's open-breach discharge (a varied breach.discharge
             # would be named like the window runner's result breach_discharge)
             "breach.length": f"{float(ds.breach_length_m[i]):.2f} m",
             "breach.mean_velocity": f"{_mean_velocity(ds, i):.4f} m/s"}
        if "diameter" not in template.get("placement", {}):
            m["placement.diameter"] = f"{float(ds.stone_size_m[i]):.2f} m"
        members.append(m)
    flood = {"fall_rate": f"{district.fall_rate} m/s"} if district.fall_rate else {"preset": district.preset}
    if district.rise_rate:
        flood["rise_rate"] = f"{district.rise_rate} m/s"
    table = {"ensemble": {"name": f"{district.name}: detailed tier", "runner": "closure", "seed": seed,
                          "replicates": int(replicates), "members": members},
             "scenario": {"name": f"{district.name} location", "description": "breach atlas, detailed tier"},
             "site": site, "flood": flood,
             "polder": {"area": f"{district.polder_area} m^2", "inundation_depth": f"{district.inundation_depth} m",
                        "pump_capacity": f"{district.pump_capacity} m^3/s"},
             "breach": {}}
    for k, v in template.items():
        if k != "scenario":
            table[k] = v
    return table


def load_template(path: Path | None) -> dict:
    if path is None:
        return {}
    try:
        return tomllib.loads(Path(path).read_text())
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise InputError(f"[detailed] scenario {path}: {exc}") from None


def run_detailed(district: District, ds: xr.Dataset, locations: list[Location], out: Path, *, client=None,
                 scheduler=None, workers=None, progress=True, console=None) -> xr.Dataset:
    """Run the detailed tier (see the module docstring) and return *ds* with its figures added."""
    from ..ensemble import run as run_ensemble
    from ..scenario.toml import dump_toml

    cfg = district.detailed or {}
    chosen = longest_first(ds, choose(ds, cfg.get("worst", 5)))
    if not chosen:
        return ds
    template = load_template(cfg.get("scenario"))
    table = ensemble_table(district, ds, locations, chosen, replicates=cfg.get("replicates", 4), template=template)
    out.mkdir(parents=True, exist_ok=True)
    spec_path = out / "detailed.toml"
    spec_path.write_text(dump_toml(table))
    res = run_ensemble(spec_path, out=out / "detailed", client=client, scheduler=scheduler, workers=workers,
                       progress=progress, console=console)
    return merge(ds, res, chosen)


def merge(ds: xr.Dataset, res: xr.Dataset, chosen: list[int]) -> xr.Dataset:
    """Put the ensemble's per-member reductions at the chosen locations (NaN elsewhere)."""
    ds = ds.copy()
    n = ds.sizes["location"]
    names = {"closure_probability": ("p_closure", "1", "probability of closure inside the window (replicates)"),
             "closure_probability_lower": ("p_closure_lower", "1", "lower bound of the 95 % Wilson interval"),
             "closure_probability_upper": ("p_closure_upper", "1", "upper bound of the 95 % Wilson interval")}
    for q in ("median", "p10", "p90"):
        names[f"tonnage_{q}"] = (f"tonnage_detailed_t_{q}", "t", f"closure simulation tonnage, {q} over replicates")
        names[f"closure_duration_{q}"] = (f"duration_detailed_h_{q}", "h",
                                          f"closure simulation duration, {q} over replicates")
    for src, (dst, units, long_name) in names.items():
        vals = np.full(n, np.nan)
        if src in res:
            v = np.asarray(res[src].values, float).ravel()
            scale = 1e-3 if src.startswith("tonnage") else (1 / 3600.0 if src.startswith("closure_duration") else 1.0)
            vals[chosen] = v[:len(chosen)] * scale
        ds[dst] = ("location", vals, {"units": units, "long_name": long_name, "grid_mapping": "crs",
                                      "coordinates": "x y"})
    ds.attrs["detailed_locations"] = ", ".join(str(i) for i in chosen)
    ds.attrs["detailed_tier"] = "closure simulation with placement replicates (breachflow ensemble, runner closure)"
    return ds



def _mean_velocity(ds: xr.Dataset, i: int) -> float:
    """``v = Q / (h_W B)``: the mean velocity that makes the closure window's ``Q_D = h_W B v`` the screening's
    open-breach discharge."""
    return float(ds.open_discharge_m3s[i]) / (float(ds.head_m[i]) * float(ds.breach_length_m[i]))
