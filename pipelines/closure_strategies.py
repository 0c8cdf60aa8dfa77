#!/usr/bin/env python3
"""Closure strategies compared: vertical vs horizontal closure (and today's line), issue 14.

    python pipelines/closure_strategies.py OUTPUT_DIR [--scenarios default typical PATH.toml ...]
                                           [--strategies line vertical horizontal] [--max-cycles N]

Closure engineering distinguishes *vertical* closure (a sill raised over the whole gap in layers) from
*horizontal* closure (the dam advanced from both breach heads, narrowing the gap); ``[placement]
positions`` selects either (:mod:`breachflow.cycle.strategies`), ``line`` is the golden-ratio line
across the breach the scenarios use today. Each scenario (``default``: the embedded default scene,
``typical``: ``examples/typical_breach.toml``, or a scenario file) runs once per strategy — the same
scenario with only ``positions`` changed (and a delivery method that can work it, :func:`member_text`), so the
same masses, rate, gap line, criteria and seed — and
the runs are compared: masses, tonnage, closure operation time (masses ÷ placement rate), cycles,
the peak gap speed reached over the closure cycles (depth-weighted mean and max over the gap section;
the open breach's beside it),
masses and tonnage carried out of the breach area (lost downstream), closed or the run's verdict, and
the model's CPU time (initial solve + re-solves + DEM; steadier than wall time on a shared machine).

Writes ``OUTPUT_DIR/closure_strategies.nc`` (CF NetCDF, schema ``closure_strategies``: the table over
scenario × strategy plus the per-cycle evolution of the gap speeds and the breach discharge),
``closure_strategies.csv``, ``closure_strategies.png`` (gap speeds and breach discharge against the
tonnage placed, one line per strategy) and one run directory per run, ``OUTPUT_DIR/<scenario>/<strategy>/``;
prints the table. Rerunning resumes: finished runs are read back, not run again.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
STRATEGIES = ("line", "vertical", "horizontal")
SCENARIOS = {"default": None, "typical": ROOT / "examples" / "typical_breach.toml"}

#: per-run scalars of the table: name → (units, long_name)
COLUMNS = {
    "masses": ("1", "masses placed"),
    "tonnage": ("kg", "mass of rock in the breach area at the end (placed minus lost)"),
    "operation_time": ("s", "closure operation time: masses placed / placement rate"),
    "cycles": ("1", "closure cycles run"),
    "closed": ("1", "closure achieved (1) or not (0)"),
    "peak_gap_mean_speed": ("m/s", "highest depth-weighted mean speed in the gap section over the closure cycles"),
    "peak_gap_max_speed": ("m/s", "highest speed in the gap section over the closure cycles"),
    "initial_gap_mean_speed": ("m/s", "depth-weighted mean speed in the gap section of the open breach"),
    "initial_gap_max_speed": ("m/s", "largest speed in the gap section of the open breach"),
    "initial_breach_discharge": ("m^3/s", "discharge through the open breach"),
    "final_breach_discharge": ("m^3/s", "discharge through the breach after the last cycle"),
    "lost_masses": ("1", "masses carried out of the breach area (lost downstream)"),
    "lost_tonnage": ("kg", "mass of rock carried out of the breach area"),
    "losses_flagged": ("1", "more than loss_limit of the placed tonnage lost (1) or not (0)"),
    "model_cpu_time": ("s", "CPU time of the initial solve, the re-solves and the DEM settles"),
    "model_wall_time": ("s", "wall time of the initial solve and of the cycles"),
}
#: per-cycle evolution (cycle 0 = the open breach): name → (units, long_name)
HISTORY = {
    "tonnage_placed": ("kg", "mass of rock in the breach area after the cycle"),
    "gap_mean_speed": ("m/s", "depth-weighted mean speed in the gap section"),
    "gap_max_speed": ("m/s", "largest speed in the gap section"),
    "breach_discharge": ("m^3/s", "discharge through the breach section"),
}


def scenario_text(name_or_path) -> tuple[str, str, Path | None]:
    """``(name, TOML text, path)`` of ``default`` (the embedded scenario), ``typical`` or a scenario file."""
    from breachflow.cycle.main import default_scenario_text

    if name_or_path in SCENARIOS:
        path = SCENARIOS[name_or_path]
        return name_or_path, (default_scenario_text() if path is None else path.read_text(encoding="utf-8")), path
    path = Path(name_or_path)
    return path.stem, path.read_text(encoding="utf-8"), path


def member_text(text: str, strategy: str, max_cycles: int | None = None) -> str:
    """The scenario *text* with ``[placement] positions = strategy`` (and ``[criteria] max_cycles``). A scenario
    whose ``[closure] method`` cannot work that strategy (split barges do not advance from the heads) gets the
    method that does: ``end_dumping`` for ``horizontal``, ``split_barge`` otherwise."""
    import tomllib

    from breachflow.cycle.delivery import delivery_method
    from breachflow.scenario.toml import scenario_with

    changes = {"placement.positions": strategy}
    method = tomllib.loads(text).get("closure", {}).get("method")
    if method is not None and strategy not in delivery_method(method).positions:
        changes["closure.method"] = "end_dumping" if strategy == "horizontal" else "split_barge"
    if max_cycles is not None:
        changes["criteria.max_cycles"] = int(max_cycles)
    return scenario_with(text, changes)


def run_member(text: str, run_dir: Path) -> dict:
    """Run (or resume, or read back) the closure of scenario *text* in *run_dir*; its row of the table
    and its history, all from the run directory's manifest (so a re-read run gives the same row)."""
    from breachflow.cycle.main import peak_gap_speed, run_closure
    from breachflow.io import RunDirectory
    from breachflow.atomic import atomic_write_text

    run_dir.mkdir(parents=True, exist_ok=True)
    path = run_dir / "scenario.in.toml"  # (relative file paths in a scenario would resolve against run_dir)
    atomic_write_text(text, path)
    out = run_dir / "run"
    rd = RunDirectory(out)
    if not (rd.exists() and rd.manifest().get("finished")):  # a finished run is read back, not resumed
        run_closure(path, out, resume=rd.exists(), plots=False)
    man = rd.manifest()
    cyc = [c["summary"] for c in man["cycles"]]
    init = man["metadata"]["initial"]
    last = cyc[-1] if cyc else {}
    closed = bool(last.get("closed"))
    verdict = (f"closed at cycle {len(cyc)} ({last.get('governing', '')})" if closed else
               (man.get("final", {}).get("verdict") or f"not closed after {len(cyc)} cycles"))
    row = {"masses": int(last.get("masses", 0)), "tonnage": 1000.0 * float(last.get("tonnage", 0.0)),
           "operation_time": float(last.get("operation_time", 0.0)), "cycles": len(cyc), "closed": int(closed),
           "peak_gap_mean_speed": peak_gap_speed(man, "gap_mean_speed"),
           "peak_gap_max_speed": peak_gap_speed(man, "gap_max_speed"),
           "initial_gap_mean_speed": float(init.get("gap_mean_speed", np.nan)),
           "initial_gap_max_speed": float(init.get("gap_max_speed", np.nan)),
           "initial_breach_discharge": float(init["breach_discharge"]),
           "final_breach_discharge": float(last.get("breach_discharge", np.nan)),
           "lost_masses": int(last.get("left_domain", 0)), "lost_tonnage": 1000.0 * float(last.get("lost_tonnage", 0.0)),
           "losses_flagged": int(bool(last.get("losses_flagged", False))),
           "model_cpu_time": float(init.get("solve_cpu_time", 0.0)) + sum(c.get("cpu_solve", 0.0) + c.get("cpu_dem", 0.0)
                                                                        for c in cyc),
           "model_wall_time": float(init.get("solve_wall_time", 0.0)) + sum(c.get("wall_time", 0.0) for c in cyc),
           "verdict": verdict}
    hist = {"tonnage_placed": [0.0] + [1000.0 * c["tonnage"] for c in cyc],
            "gap_mean_speed": [init.get("gap_mean_speed", np.nan)] + [c.get("gap_mean_speed", np.nan) for c in cyc],
            "gap_max_speed": [init.get("gap_max_speed", np.nan)] + [c.get("gap_max_speed", np.nan) for c in cyc],
            "breach_discharge": [init["breach_discharge"]] + [c["breach_discharge"] for c in cyc]}
    return {"row": row, "history": hist}


def table_dataset(results: dict, scenarios: list[str], strategies: list[str]):
    """The CF Dataset of *results* ``{(scenario, strategy): run_member(...)}``: the table over
    ``scenario`` × ``strategy`` and the evolution over ``cycle`` (NaN beyond a run's last cycle)."""
    import xarray as xr

    n_cyc = max(len(r["history"]["gap_mean_speed"]) for r in results.values())
    shape = (len(scenarios), len(strategies))
    data = {}
    for name, (units, long_name) in COLUMNS.items():
        ints = units == "1"
        arr = np.zeros(shape, np.int32) if ints else np.full(shape, np.nan)
        for i, sc in enumerate(scenarios):
            for j, st in enumerate(strategies):
                arr[i, j] = results[(sc, st)]["row"][name]
        data[name] = (("scenario", "strategy"), arr, {"units": units, "long_name": long_name})
    verdict = np.array([[results[(sc, st)]["row"]["verdict"] for st in strategies] for sc in scenarios], dtype=object)
    data["verdict"] = (("scenario", "strategy"), verdict, {"long_name": "closed at cycle N, or why the run ended without closure"})
    for name, (units, long_name) in HISTORY.items():
        arr = np.full(shape + (n_cyc,), np.nan)
        for i, sc in enumerate(scenarios):
            for j, st in enumerate(strategies):
                h = np.asarray(results[(sc, st)]["history"][name], float)
                arr[i, j, :h.size] = h
        data[name] = (("scenario", "strategy", "cycle"), arr, {"units": units, "long_name": long_name})
    ds = xr.Dataset(data, coords={
        "scenario": ("scenario", np.array(scenarios, dtype=object), {"long_name": "closure scenario"}),
        "strategy": ("strategy", np.array(strategies, dtype=object),
                     {"long_name": "placement strategy ([placement] positions)"}),
        "cycle": ("cycle", np.arange(n_cyc, dtype=np.int32), {"long_name": "closure cycle <g> (0: the open breach)",
                                                             "units": "1"})})
    ds.attrs.update(Conventions="CF-1.10", title="breachflow closure strategies compared (issue 14)",
                    source="pipelines/closure_strategies.py", history="")
    return ds


def figure(ds, path: Path) -> Path:
    """Per scenario (rows): gap mean speed, gap max speed and breach discharge against the tonnage
    placed, one line per strategy (cycle 0 the open breach; the last point of a closed run starred)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from breachflow.atomic import atomic_path

    scen = [str(s) for s in ds["scenario"].values]
    strat = [str(s) for s in ds["strategy"].values]
    cols = (("gap_mean_speed", "gap speed, mean (m/s)"), ("gap_max_speed", "gap speed, max (m/s)"),
            ("breach_discharge", "breach discharge (m³/s)"))
    fig, axes = plt.subplots(len(scen), 3, figsize=(13, 3.6 * len(scen)), squeeze=False, constrained_layout=True)
    for i, sc in enumerate(scen):
        for j, (var, label) in enumerate(cols):
            ax = axes[i, j]
            for k, st in enumerate(strat):
                t = ds["tonnage_placed"].values[i, k] / 1000.0
                v = ds[var].values[i, k]
                ok = np.isfinite(t) & np.isfinite(v)
                ax.plot(t[ok], v[ok], "o-", ms=3, color=f"C{k}", label=st)
                if int(ds["closed"].values[i, k]) and ok.any():
                    ax.plot(t[ok][-1], v[ok][-1], "*", ms=12, color=f"C{k}")
            ax.set_xlabel("rock in the breach area (t)")
            ax.set_ylabel(label)
            ax.set_ylim(bottom=0)
            ax.set_title(f"{sc}: {label.split(' (')[0]}")
        axes[i, 0].legend(fontsize=8, title="strategy (★ closed)")
    fig.suptitle("Closure strategies: gap speed and breach discharge as the closure proceeds")
    with atomic_path(path, suffix=".png") as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)
    return path


def write_csv(ds, path: Path) -> Path:
    from breachflow.atomic import atomic_write_text

    names = list(COLUMNS) + ["verdict"]
    lines = [",".join(["scenario", "strategy"] + [f"{n}_{COLUMNS[n][0].replace('^', '').replace('/', '_per_')}"
                                                  if n in COLUMNS and COLUMNS[n][0] != "1" else n for n in names])]
    for i, sc in enumerate(ds["scenario"].values):
        for j, st in enumerate(ds["strategy"].values):
            vals = [str(ds[n].values[i, j]) for n in COLUMNS] + ['"' + str(ds["verdict"].values[i, j]).replace('"', "'") + '"']
            lines.append(",".join([str(sc), str(st)] + vals))
    return atomic_write_text("\n".join(lines) + "\n", path)


def print_table(ds, console) -> None:
    from rich.table import Table

    tab = Table(title="Closure strategies (model CPU time: initial solve + re-solves + DEM)")
    for col in ("scenario", "strategy", "masses", "tonnage (t)", "operation (h)", "cycles",
                "peak gap speed mean / max (m/s) [open breach]", "lost (masses, t)", "CPU (s)", "closed / verdict"):
        tab.add_column(col, overflow="fold")
    for i, sc in enumerate(ds["scenario"].values):
        for j, st in enumerate(ds["strategy"].values):
            v = {n: ds[n].values[i, j] for n in list(COLUMNS) + ["verdict"]}
            tab.add_row(str(sc), str(st), f"{v['masses']}", f"{v['tonnage'] / 1000:.1f}",
                        f"{v['operation_time'] / 3600:.2f}", f"{v['cycles']}",
                        f"{v['peak_gap_mean_speed']:.2f} / {v['peak_gap_max_speed']:.2f} "
                        f"[{v['initial_gap_mean_speed']:.2f} / {v['initial_gap_max_speed']:.2f}]",
                        f"{v['lost_masses']} ({v['lost_tonnage'] / 1000:.1f} t)"
                        + (" FLAGGED" if v["losses_flagged"] else ""),
                        f"{v['model_cpu_time']:.1f}", str(v["verdict"]))
    console.print(tab)


def compare(scenarios, strategies=STRATEGIES, out: Path = Path("closure_strategies"), *, max_cycles=None,
            console=None):
    """Run every scenario (names or paths, :func:`scenario_text`) with every strategy in *out*; write and
    return the table Dataset (validated against ``data_schemas/closure_strategies.json``)."""
    from breachflow.atomic import atomic_write_netcdf
    from breachflow.schemas import validate

    out = Path(out)
    results, names = {}, []
    for spec in scenarios:
        name, text, _ = scenario_text(spec)
        names.append(name)
        for st in strategies:
            if console is not None:
                console.print(f"[bold]{name}[/] with [bold]{st}[/] …", highlight=False)
            results[(name, st)] = run_member(member_text(text, st, max_cycles), out / name / st)
    ds = validate(table_dataset(results, names, list(strategies)), "closure_strategies")
    atomic_write_netcdf(ds, out / "closure_strategies.nc")
    write_csv(ds, out / "closure_strategies.csv")
    figure(ds, out / "closure_strategies.png")
    return ds


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("output", type=Path, nargs="?", default=Path("closure_strategies"))
    ap.add_argument("--scenarios", nargs="+", default=list(SCENARIOS),
                    help="'default' (embedded), 'typical' (examples/typical_breach.toml) or scenario files")
    ap.add_argument("--strategies", nargs="+", default=list(STRATEGIES), help="placement strategies to compare")
    ap.add_argument("--max-cycles", type=int, default=None, help="override [criteria] max_cycles of every run")
    args = ap.parse_args(argv)

    from rich.console import Console

    from breachflow.cycle.strategies import placement_strategies

    for st in args.strategies:
        placement_strategies.get(st)  # an unknown name fails before any run
    console = Console()
    ds = compare(args.scenarios, args.strategies, args.output, max_cycles=args.max_cycles, console=console)
    print_table(ds, console)
    console.print(f"wrote {args.output / 'closure_strategies.nc'}, .csv, .png", highlight=False)
    return 0


if __name__ == "__main__":
    sys.exit(main())
