"""The closure plan of a run in time (``[closure] method``): what an engineer asks of a closure.

Method, start, finish (dates when the breach is dated), tonnage placed (per material, in place and
carried away), the head across the breach and the breach discharge over the operation, the leakage at
the end (as polder rise per day and against the pumps), and whether the closure fits in its window:
the breach balance and the inundation limit of the simulated polder, and the report's closure window
(linear model, :func:`~breachflow.scenario.closure_window`) when the scenario gives one.

:func:`closure_plan` builds the plan (a JSON-serialisable dict) from a finished run directory and its
timeline; :func:`write_closure_plan` writes ``closure_plan.json`` and ``closure_plan.png`` (head,
discharge and placed tonnage against operation time); :func:`plan_lines` is the printed section.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

HOUR, DAY = 3600.0, 86400.0


def _date(timeline, t):
    if timeline is None or timeline.breach_date is None or t is None or not np.isfinite(t):
        return None
    return str(timeline.breach_date + np.timedelta64(int(round(t)), "s"))


def _materials(rundir, last_cycle: int) -> list[dict]:
    """Tonnage per material of the masses placed (in place and carried away), from the last cycle file:
    grouped by the ``particle_material`` names when the file has them, else by density."""
    import xarray as xr

    try:
        with xr.open_dataset(rundir.cycle_path(last_cycle), decode_times=False) as ds:
            placed = np.asarray(ds["particle_placed_cycle"].values).ravel() > 0
            mass = np.asarray(ds["particle_mass"].values, float).ravel() if "particle_mass" in ds else None
            if mass is None:
                r = np.asarray(ds["particle_radius"].values, float).ravel()
                rho = np.asarray(ds["particle_density"].values, float).ravel()
                mass = 4.0 / 3.0 * np.pi * r ** 3 * rho
            if "particle_material" in ds:
                da = ds["particle_material"]
                names = np.asarray(da.values).ravel()
                if "flag_meanings" in da.attrs:  # a flag variable: each value's material name
                    words = dict(zip(np.asarray(da.attrs["flag_values"]).ravel().tolist(),
                                     str(da.attrs["flag_meanings"]).split()))
                    names = np.array([words.get(int(v), "") for v in names])
                names = names.astype(str)
            else:
                rho = np.asarray(ds["particle_density"].values, float).ravel()
                names = np.array([f"density {v:.0f} kg/m3" if np.isfinite(v) else "" for v in rho])
            active = np.asarray(ds["particle_active"].values).ravel().astype(bool) if "particle_active" in ds else \
                np.isfinite(np.asarray(ds["particle_x"].values, float).ravel())
    except (OSError, KeyError):
        return []
    out = []
    for name in sorted(set(names[placed])):
        sel = placed & (names == name)
        m = mass[sel]
        out.append({"material": name, "masses": int(sel.sum()), "placed_t": float(np.nansum(m)) / 1000.0,
                    "in_place_t": float(np.nansum(m[active[sel]])) / 1000.0,
                    "lost_t": float(np.nansum(m[~active[sel]])) / 1000.0,
                    "unit_mass_t": [float(np.nanmin(m)) / 1000.0, float(np.nanmax(m)) / 1000.0]})
    return out


def closure_plan(rundir, setup, scenario=None) -> dict | None:
    """The plan of a finished run with a timeline (None without one)."""
    tl = setup.timeline
    if tl is None:
        return None
    man = rundir.manifest()
    cycles = [c["summary"] for c in man.get("cycles", [])]
    start_state = man.get("metadata", {}).get("timeline_start", {})
    last = cycles[-1] if cycles else {}
    finish = float(last.get("operation_time", tl.start))
    q_end = float(last.get("breach_discharge", start_state.get("timeline_discharge", float("nan"))))
    seep = float(last.get("seepage_discharge", 0.0))
    pol = tl.polder
    rows = [{"phase": h["phase"], "time_s": h["time"], "flood_level_m": h["flood_level"],
             "polder_level_m": h["polder_level"], "head_m": h["flood_level"] - max(h["polder_level"], tl.bottom),
             "breach_discharge_m3_s": h["breach_discharge"], "delivered_t": h["delivered_t"]}
            for h in start_state.get("prestart", [])]
    for c in cycles:
        st = c.get("timeline", {})
        rows.append({"phase": f"cycle {c['cycle']}", "time_s": c["operation_time"], "flood_level_m": c["flood_level"],
                     "polder_level_m": c["polder_level"],
                     "head_m": c["flood_level"] - max(c["polder_level"], tl.bottom),
                     "breach_discharge_m3_s": c["breach_discharge"], "delivered_t": st.get("delivered_t", 0.0)})
    # the window of the simulated polder: the breach balance, and the inundation limit when [polder] gives one
    balance = last.get("timeline", {}).get("balance_time", start_state.get("balance_time"))
    inundation = None
    d_i = None
    if scenario is not None and "polder" in scenario and scenario["polder"].inundation_depth is not None:
        d_i = float(scenario["polder"].inundation_depth)
        deep = [r for r in rows if r["polder_level_m"] - pol.initial_level >= d_i]
        inundation = float(deep[0]["time_s"]) if deep else None
    # the closure window of the breach left open (weir of the growing breach, the same flood and polder):
    # the deadline; the balance or inundation reached during the run (the pile slows the filling) come later
    open_window = tl.open_breach_window(d_i)
    limits = [v for v in (balance, inundation, open_window) if v is not None and np.isfinite(v)]
    window_sim = min(limits) if limits else None
    report_window = None
    if scenario is not None and all(k in scenario for k in ("flood", "polder", "breach")) and d_i is not None:
        try:
            from ..scenario import closure_window

            report_window = float(closure_window(**scenario.window_kwargs())["closure_window"])
        except Exception:  # noqa: BLE001 - the report's window is a comparison, not the plan
            report_window = None
    closed = bool(last.get("closed"))
    seal = None
    placed_t = float(last.get("timeline", {}).get("delivered_t", 0.0))
    seal = man.get("metadata", {}).get("seal")
    if seal and seal.get("steps"):  # the seal after the rock (cycle/sealing.py): its delivery, leakage and tonnage
        finish = float(seal["finish_s"])
        q_end = float(seal["leakage_m3_s"])
        st = seal.get("timeline", {})
        rows.append({"phase": "seal", "time_s": finish, "flood_level_m": st.get("flood_level", float("nan")),
                     "polder_level_m": st.get("polder_level", float("nan")),
                     "head_m": st.get("flood_level", float("nan")) - max(st.get("polder_level", float("nan")), tl.bottom),
                     "breach_discharge_m3_s": q_end, "delivered_t": placed_t + float(seal["seal_tonnage_t"])})
        closed = closed and bool(seal.get("sealed"))
    frozen = bool(getattr(tl, "frozen", False))
    if frozen:  # the levels held (cycle/frozen_timeline.py): the report's linear window is the only one
        window_sim = report_window
    fits = closed and (window_sim is None or finish <= window_sim)
    plan = {
        "method": tl.method.name, "method_description": tl.method.describe(),
        "capacity_t_h": tl.method.capacity * HOUR / 1000.0, "working_hours_per_day": tl.method.working_hours / HOUR,
        "start_s": tl.start, "start_date": _date(tl, tl.start),
        "finish_s": finish, "finish_date": _date(tl, finish),
        "duration_s": finish - tl.start, "duration_days": (finish - tl.start) / DAY,
        "closed": closed, "verdict": man.get("final", {}).get("verdict", ""),
        "cycles": len(cycles), "placed_t": placed_t,
        "in_place_t": float(last.get("tonnage", 0.0)), "lost_t": float(last.get("lost_tonnage", 0.0)),
        "breach_length_m": tl.length,
        "placed_t_per_m": placed_t / tl.length if tl.length > 0 else float("nan"),
        "average_rate_t_h": placed_t / ((finish - tl.start) / HOUR) if finish > tl.start else float("nan"),
        "materials": _materials(rundir, int(last["cycle"])) if cycles else [],
        "flood": tl.stage.source,
        # an ingested flow model: the method's clock only, the flood and the polder held (cycle/frozen_timeline.py)
        "flood_frozen": frozen,
        "polder": {"area_m2": pol.area, "pump_capacity_m3_s": pol.pump_capacity, "initial_level_m": pol.initial_level,
                   "level_at_start_m": start_state.get("polder_level"), "level_at_finish_m": last.get("polder_level")},
        "leakage_end": {"breach_discharge_m3_s": q_end, "seepage_m3_s": seep,
                        "polder_rise_m_per_day": pol.rise_per_day(q_end) if np.isfinite(q_end) and np.isfinite(pol.area)
                        else None,  # a frozen flood without [polder]: no area
                        "pump_capacity_m3_s": pol.pump_capacity,
                        "within_pumps": bool(np.isfinite(q_end) and q_end <= pol.pump_capacity)},
        "window": {"open_breach_window_s": open_window if np.isfinite(open_window) else None,
                   # what the window's weir was calibrated on: the open breach at its full size, whatever the start
                   "calibration": _window_calibration(man, tl),
                   "balance_time_s": balance, "inundation_time_s": inundation, "window_s": window_sim,
                   "window_date": _date(tl, window_sim), "report_closure_window_s": report_window,
                   "fits": bool(fits)},
        "timeline": rows,
        # the rock stage's end as last judged (cycle/rock_end.py): the rule, steady or not, the crest against the flood
        "rock_end": next((dict(c["rock_end"], cycle=c["cycle"]) for c in reversed(cycles) if c.get("rock_end")), None),
    }
    if seal and seal.get("steps"):
        plan["seal"] = {k: seal.get(k) for k in ("sealed", "verdict", "method", "capacity_t_h", "start_s", "finish_s",
                                                  "work_s", "seal_thickness_m", "tonnage_t", "seal_tonnage_t",
                                                  "leakage_m3_s", "net_rise_m_per_day", "steps")}
        plan["seal"]["finish_date"] = _date(tl, finish)
        plan["leakage_end"]["seepage_m3_s"] = None  # the split is not computed for the sealed pile
    return plan


def _window_calibration(man: dict, tl) -> dict | None:
    """The window weir's calibration as recorded at the run's start (the manifest), without its steps."""
    cal = man.get("metadata", {}).get("timeline_start", {}).get("window_calibration") or getattr(
        tl, "window_calibration", None)
    if not cal:
        return None
    return {k: v for k, v in cal.items() if k != "steps"}


def _num(x: float) -> str:
    return f"{x:,.0f}" if abs(x) >= 10 else f"{x:.2g}"


def plan_lines(plan: dict) -> list[str]:
    """The closure plan as printed lines."""
    def when(s, d):
        return f"{s / HOUR:,.1f} h after the breach" + (f" ({d})" if d else "")

    w, leak = plan["window"], plan["leakage_end"]
    lines = [f"closure plan: {plan['method_description']}",
             f"  start   {when(plan['start_s'], plan['start_date'])}",
             f"  finish  {when(plan['finish_s'], plan['finish_date'])}: {plan['duration_days']:.2f} days of operation, "
             f"{'closed' if plan['closed'] else 'NOT closed'}" + (f" ({plan['verdict']})" if plan["verdict"] else ""),
             f"  tonnage {plan['placed_t']:,.0f} t placed ({_num(plan['placed_t_per_m'])} t per m of breach), "
             f"{plan['in_place_t']:,.0f} t in place, {plan['lost_t']:,.0f} t carried away; average "
             f"{plan['average_rate_t_h']:,.0f} t/h"]
    for m in plan["materials"]:
        lines.append(f"    {m['material']}: {m['placed_t']:,.0f} t in {m['masses']} units of "
                     f"{m['unit_mass_t'][0]:.3g}–{m['unit_mass_t'][1]:.3g} t ({m['lost_t']:,.0f} t lost)")
    re_ = plan.get("rock_end")
    if re_:
        from .rock_end import RockEnd

        end = RockEnd.from_dict(re_)
        lines.append(f"  rock    cycle {re_['cycle']}: " + (end.statement() if end is not None else
                                                            "rock stage end: " + (re_.get("reason") or "held")))
    sl = plan.get("seal")
    if sl:
        layers = ", ".join(f"{k} {v:,.0f} t" for k, v in sl["tonnage_t"].items())
        lines.append(f"  seal    {sl['seal_tonnage_t']:,.0f} t ({layers}; seal layer {sl['seal_thickness_m']:.2f} m) by "
                     f"{sl['method']} at {sl['capacity_t_h']:,.0f} t/h: {sl['work_s'] / HOUR:,.1f} h of work, done "
                     f"{sl['finish_s'] / HOUR:,.1f} h after the breach; {sl['verdict']}")
    rows = plan["timeline"]
    if rows:
        lines.append(f"  head    {rows[0]['head_m']:.2f} m at the breach, "
                     + ", ".join(f"{r['head_m']:.2f} m at {r['time_s'] / HOUR:,.1f} h" for r in rows[-3:]))
    rise = leak["polder_rise_m_per_day"]
    seep = "" if leak["seepage_m3_s"] is None else f" (seepage {leak['seepage_m3_s']:.2f})"
    lines.append(f"  leakage at the end {leak['breach_discharge_m3_s']:.2f} m³/s{seep}: "
                 + (f"polder rise {rise * 100:.1f} cm/day, " if rise is not None else "")
                 + f"pumps {leak['pump_capacity_m3_s']:g} m³/s ({'within' if leak['within_pumps'] else 'beyond'} them)")
    parts = []
    if w["open_breach_window_s"] is not None:
        cal = w.get("calibration")
        on = "" if not cal else (
            f" (its weir calibrated on the open breach at full size, {cal['time_s'] / HOUR:,.1f} h after the breach: "
            f"{cal['weir_coefficient']:.3f} m^0.5/s, {cal['model_discharge_m3_s']:,.0f} m³/s; the same for every start)")
        parts.append(f"the breach left open would reach the balance or the inundation limit at "
                     f"{w['open_breach_window_s'] / HOUR:,.1f} h" + on)
    if w["balance_time_s"] is not None:
        parts.append(f"balance reached in the run at {w['balance_time_s'] / HOUR:,.1f} h")
    if w["inundation_time_s"] is not None:
        parts.append(f"inundation limit reached in the run at {w['inundation_time_s'] / HOUR:,.1f} h")
    if w["report_closure_window_s"] is not None:
        parts.append(f"report's linear window {w['report_closure_window_s'] / HOUR:,.1f} h")
    if plan.get("flood_frozen"):
        lines.append(f"  flood   {plan['flood']}: the levels do not follow the flood or the polder's filling, "
                     f"and the breach left open is not simulated")
        if w["report_closure_window_s"] is None:
            lines.append("  window  none: no simulated window, and no [flood], [polder] and [breach] for the "
                         "report's linear one")
            return lines
    lines.append("  window  " + ("; ".join(parts) if parts else "no balance or inundation limit reached")
                 + f": {'fits' if w['fits'] else 'does NOT fit'}")
    return lines


def write_closure_plan(rundir, setup, scenario=None, *, plot: bool = True) -> dict | None:
    """Write ``closure_plan.json`` (and ``closure_plan.png``) into the run directory; returns the plan."""
    plan = closure_plan(rundir, setup, scenario)
    if plan is None:
        return None
    path = Path(rundir.path)
    (path / "closure_plan.json").write_text(json.dumps(plan, indent=1, default=_json_default))
    if plot and plan["timeline"]:
        plan["plot"] = str(plot_closure_plan(plan, path / "closure_plan.png"))
    return plan


def _json_default(o):
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    if isinstance(o, np.bool_):
        return bool(o)
    return str(o)


def plot_closure_plan(plan: dict, out) -> Path:
    """Head across the breach, breach discharge and placed tonnage against operation time (PNG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = plan["timeline"]
    t = np.array([r["time_s"] for r in rows]) / HOUR
    fig, ax = plt.subplots(3, 1, figsize=(7.5, 7.5), sharex=True, constrained_layout=True)
    ax[0].plot(t, [r["flood_level_m"] for r in rows], label="flood level")
    ax[0].plot(t, [r["polder_level_m"] for r in rows], label="polder level")
    ax[0].plot(t, [r["head_m"] for r in rows], "k--", label="head across the breach")
    ax[0].set_ylabel("level / head (m)")
    ax[0].legend(fontsize=8)
    ax[1].plot(t, [r["breach_discharge_m3_s"] for r in rows], "o-", ms=3)
    ax[1].axhline(plan["polder"]["pump_capacity_m3_s"], color="grey", lw=0.8, ls=":", label="pump capacity")
    ax[1].set_ylabel("breach discharge (m³/s)")
    ax[1].legend(fontsize=8)
    ax[2].step(t, [r["delivered_t"] for r in rows], where="post")
    ax[2].set_ylabel("placed (t)")
    ax[2].set_xlabel("operation time since the breach (h)")
    for a in ax:
        a.axvline(plan["start_s"] / HOUR, color="green", lw=0.8)
        if plan["window"]["window_s"] is not None:
            a.axvline(plan["window"]["window_s"] / HOUR, color="red", lw=0.8)
    ax[0].set_title(f"closure plan: {plan['method']}, start {plan['start_s'] / HOUR:g} h "
                    f"({'closed' if plan['closed'] else 'not closed'}; green start, red end of window)", fontsize=9)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return Path(out)
