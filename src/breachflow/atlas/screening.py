"""The screening tier of a breach atlas: what one candidate breach would do, in seconds of CPU.

For a :class:`~breachflow.atlas.locations.Location` and a :class:`~breachflow.atlas.config.District`:

1. head ``h_W = flood level - protected-side ground`` (a location with ``h_W <= 0.1 m`` is not at risk);
2. breach length ``B`` when the closure can start: the chosen growth equation at the development time,
   capped by the maximum-length equation (docs/theory.md, *Breach growth*; report eqs. 2.2-2.11);
3. open-breach flow: the embedded shallow-water solver on a local domain cut from the terrain around the
   breach (``flow = "swe"``: discharge through the gap, peak depth-averaged speed and the depth there) or
   the broad-crested weir ``Q = C (b h^1.5 + 0.79 m h^2.5)`` with critical flow in the gap
   (``flow = "weir"``: ``u = Q / (B 2/3 h_W)``);
4. closure window ``(t_Q, t_I, t_B)`` of the linearised flood with that discharge (docs/theory.md,
   *Closure window*; report §2.4);
5. stone size (the larger of Izbash for an exposed stone and Shields) for the gap speed and the rock
   tonnage to fill the breach section up to the crest (:func:`breachflow.scenario.stone.stone_size`);
6. per closure method: duration = mobilisation + tonnage / capacity over the working hours, and whether
   the closure ends within the window (``finish = development time + duration <= closure window``).
"""
from __future__ import annotations

import math
import time
import warnings

import numpy as np

from ..errors import BreachflowWarning, InputError
from ..scenario.geometry import LeveeGeometry
from ..scenario.growth import breach_length, max_breach_length, max_length_equations
from ..scenario.stone import StoneEstimate, fill_volume, izbash_diameter, stone_size
from ..scenario.window import closure_window
from .config import District
from .locations import Location

#: the screening's breach is a rectangle: the length B of the growth equation is its width at the bottom
#: (weir discharge, fill volume, stone sizing) and at the crest (the breach cut into the terrain); vertical
#: walls, stated rather than left to the breach default (1V:0.5H), which would narrow the bottom by the
#: levee height. The detailed tier's sites state the same (:mod:`breachflow.atlas.detailed`).
WALL_SLOPE = 0.0

#: a closure that ends less than this many hours before its window closes is "tight" on the map
TIGHT_MARGIN_H = 12.0
#: the smallest head (m) at which a location counts as at risk
MIN_HEAD = 0.1
GRAVITY = 9.81
#: screening fields that are floats (NaN when not computed) and their units / long names
FIELDS = {
    "breach_chainage": ("m", "chainage of the candidate breach centre along the levee line"),
    "crest_elevation_m": ("m", "levee crest elevation at the location"),
    "protected_ground_m": ("m", "protected-side ground elevation (the breach bottom)"),
    "levee_height_m": ("m", "levee height above the protected-side ground"),
    "head_m": ("m", "flood level above the breach bottom (h_W)"),
    "breach_length_m": ("m", "breach length when the closure starts (growth equation, capped)"),
    "max_breach_length_m": ("m", "maximum breach length (maximum-length equation)"),
    "open_discharge_m3s": ("m3 s-1", "open-breach discharge"),
    "gap_speed_ms": ("m s-1", "peak depth-averaged speed in the breach gap"),
    "gap_depth_m": ("m", "water depth at the peak speed"),
    "closure_window_h": ("h", "closure window: time from breaching until balance or inundation"),
    "balance_time_h": ("h", "time until the polder level balances the flood (t_Q)"),
    "inundation_time_h": ("h", "time until the polder reaches the inundation depth (t_I)"),
    "stone_size_m": ("m", "design stone diameter (Izbash exposed / Shields)"),
    "stone_mass_t": ("t", "design stone mass"),
    "tonnage_t": ("t", "rock to fill the breach section up to the crest"),
    "duration_h": ("h", "closure duration with the best method (mobilisation + delivery)"),
    "finish_h": ("h", "closure finish time after breaching with the best method"),
    "margin_h": ("h", "closure window minus finish time (negative: too late)"),
    "solve_cpu_s": ("s", "CPU time of the screening of this location"),
}


def screen(loc: Location, district: District, *, terrain=None, levee=None) -> dict:
    """The screening figures of one location (a flat dict of floats, strings and bools; SI inside,
    hours and tonnes in the names that say so)."""
    t0 = time.process_time()
    out = {k: float("nan") for k in FIELDS}
    out.update(breach_chainage=loc.chainage, crest_elevation_m=loc.crest, protected_ground_m=loc.protected_ground,
               levee_height_m=loc.levee_height, status="ok", method="", feasible=False, at_risk=False,
               governing="", flow_model=district.flow, message="", stone_criterion="")
    head = district.flood_level - loc.protected_ground
    out["head_m"] = head
    if not (np.isfinite(head) and head > MIN_HEAD):
        out.update(status="not at risk", message=f"flood level {district.flood_level:.2f} m is not above the "
                                                  f"protected ground {loc.protected_ground:.2f} m")
        out["solve_cpu_s"] = time.process_time() - t0
        return out
    out["at_risk"] = True
    B, B_max = _breach_length(loc, district, head)
    out.update(breach_length_m=B, max_breach_length_m=B_max)
    if district.flow == "swe":
        q, u, h = _swe_flow(loc, district, B, terrain=terrain, levee=levee)
    else:
        q, u, h = _weir_flow(head, B)
    out.update(open_discharge_m3s=q, gap_speed_ms=u, gap_depth_m=h)
    win = _window(district, head, q)
    out.update(win)
    st, criterion = _stone(u, h, B, loc, district)
    out.update(stone_size_m=st.design_diameter, stone_mass_t=st.stone_mass / 1000.0, tonnage_t=st.tonnage,
               stone_criterion=criterion)
    window_s = win["closure_window_h"] * 3600.0
    best = None
    for m in district.methods:
        dur = m.duration(st.tonnage * 1000.0)
        finish = district.development_time + dur
        ok = (not np.isfinite(window_s)) or finish <= window_s
        out[f"duration_h_{m.name}"] = dur / 3600.0
        out[f"feasible_{m.name}"] = bool(ok)
        key = (not ok, dur)
        if best is None or key < best[0]:
            best = (key, m, dur, finish, ok)
    _, m, dur, finish, ok = best
    out.update(method=m.name, duration_h=dur / 3600.0, finish_h=finish / 3600.0, feasible=bool(ok),
               margin_h=(window_s - finish) / 3600.0 if np.isfinite(window_s) else float("inf"))
    out["solve_cpu_s"] = time.process_time() - t0
    return out


def _stone(u: float, h: float, B: float, loc: Location, district: District):
    """The design stone and the tonnage: the larger of Izbash (exposed) and Shields; where Shields has no
    stable size at this depth (its critical speed peaks at a finite diameter), Izbash alone, and the
    criterion says so."""
    kw = dict(breach_depth=max(loc.levee_height, 0.1), density=district.rock_density, porosity=district.porosity,
              side_slope=district.side_slope, wall_slope=WALL_SLOPE)
    try:
        return stone_size(u, max(h, 0.05), B, **kw), "izbash_exposed+shields"
    except InputError:
        pass
    D = float(izbash_diameter(u, district.rock_density, placement="exposed"))
    H = kw["breach_depth"]
    crest_width = max(3.0 * D, 1.0)  # as stone_size: a dam crest three stones wide
    V = fill_volume(B, H, crest_width, district.side_slope, WALL_SLOPE)
    rock = (1.0 - district.porosity) * V
    rho = district.rock_density
    est = StoneEstimate(velocity=u, depth=h, density=rho, d_izbash_exposed=D,
                        d_izbash_embedded=float(izbash_diameter(u, rho, placement="embedded")), d_shields=float("nan"),
                        design_diameter=D, stone_mass=rho * math.pi / 6.0 * D ** 3, bulk_volume=V, rock_volume=rock,
                        tonnage=rho * rock / 1000.0, porosity=district.porosity, side_slope=district.side_slope,
                        crest_width=crest_width, height=H, breach_length=B)
    return est, "izbash_exposed (no stable size by Shields at this depth)"


def _breach_length(loc: Location, district: District, head: float) -> tuple[float, float]:
    levee = LeveeGeometry(height=max(loc.levee_height, 0.1), crown_width=max(loc.crown_width, 0.0),
                          flood_slope=loc.flood_slope, protected_slope=loc.protected_slope)
    cap = district.max_length
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BreachflowWarning)  # applicability notes of the growth equations
        B = float(breach_length(district.growth, f"{district.development_time} s", surge_height=f"{head} m",
                                levee=levee, max_length=cap))
        if cap in max_length_equations:
            B_max = float(max_breach_length(cap, f"{head} m"))
        else:
            B_max = float(np.nan)
    if not B > 0:
        raise InputError(f"breach growth {district.growth!r} gives no breach at chainage {loc.chainage:.0f} m")
    return B, B_max


def _weir_flow(head: float, B: float) -> tuple[float, float, float]:
    from ..scenario.discharge import weir_discharge

    q = weir_discharge(f"{head} m", bottom_width=f"{B} m", wall_slope=WALL_SLOPE)
    hc = 2.0 / 3.0 * head
    return q, q / (B * hc), hc


def _window(district: District, head: float, q: float) -> dict:
    kw = dict(polder_area=f"{district.polder_area} m^2", inundation_depth=f"{district.inundation_depth} m",
              surge_height=f"{head} m", breach_discharge=f"{q} m^3/s",
              pump_capacity=f"{district.pump_capacity} m^3/s")
    if district.preset is not None:
        kw["preset"] = district.preset
    if district.fall_rate is not None:
        kw["fall_rate"] = f"{district.fall_rate} m/s"
    if district.rise_rate is not None:
        kw["rise_rate"] = f"{district.rise_rate} m/s"
    if district.flood_duration is not None:
        kw["flood_duration"] = f"{district.flood_duration} s"
    ds = closure_window(**kw)
    gov = {0: "balance", 1: "inundation", 2: "none"}[int(ds["governing"])]
    return {"closure_window_h": float(ds["closure_window"]) / 3600.0,
            "balance_time_h": float(ds["balance_time"]) / 3600.0,
            "inundation_time_h": float(ds["inundation_time"]) / 3600.0, "governing": gov}


def _swe_flow(loc: Location, district: District, B: float, *, terrain=None, levee=None) -> tuple[float, float, float]:
    """Discharge, peak speed and depth in the gap from the embedded solver on a local domain at the breach."""
    from ..field.derived import peak_speed
    from ..swe.section import flow_sign, snapshot_discharge
    from ..swe import SWEOptions, SWESimulation
    from ..site.domain import SiteSpec, build_site

    spec = SiteSpec(terrain=district.terrain, levee=district.levee, crs=district.crs,
                    terrain_units=district.terrain_units, breach_at=loc.chainage, breach_length=B,
                    breach_bottom=loc.protected_ground, breach_wall_slope=WALL_SLOPE, flood_level=district.flood_level,
                    flood_side=district.flood_side, manning_n=district.manning_n, scenario=district.path)
    site = build_site(spec, district.resolution, terrain=terrain, levee=levee)
    dom = site.domain
    xc, yc = site.centre
    X, Y = np.meshgrid(dom.x, dom.y)
    region = np.hypot(X - xc, Y - yc) <= 2.0 * B + 2.0 * district.resolution
    sim = SWESimulation(dom, SWEOptions(order=1, courant=0.45))
    section = (xc - 0.5 * B, xc + 0.5 * B, yc)
    sim.run_to_steady(district.tolerance, district.t_max, region=region, section=section)
    ds = sim.snapshot()
    q = flow_sign(site.flood_sign) * snapshot_discharge(ds, (xc - 0.5 * B, xc + 0.5 * B), yc) + 0.0
    w = site.half_width
    pk = peak_speed(ds, x_range=(xc - 0.5 * B, xc + 0.5 * B), y_range=(yc - w, yc + w))
    return float(q), float(pk["speed"]), float(pk["depth"])


def feasibility_class(rec: dict) -> str:
    """One word for the map: ``not at risk``, ``feasible``, ``tight`` (the closure ends less than
    :data:`TIGHT_MARGIN_H` hours before the window closes) or ``not feasible``."""
    if rec.get("status") != "ok":
        return rec.get("status", "failed")
    if not rec.get("at_risk"):
        return "not at risk"
    if not rec.get("feasible"):
        return "not feasible"
    margin = rec.get("margin_h", math.inf)
    return "tight" if margin < TIGHT_MARGIN_H else "feasible"
