#!/usr/bin/env python3
"""Reproduce the report's Table 2.6 grid of closure windows in one vectorised call (docs/theory.md, *Closure window*).

    python pipelines/table_2_6.py OUTPUT_DIR

Writes ``OUTPUT_DIR/table_2_6.nc`` (CF NetCDF: t_Q, t_I, t_B, depth, governing constraint over surge height ×
fall rate × breach length × polder area × inundation depth) and ``OUTPUT_DIR/table_2_6.png`` (the grid as
the report lays it out: t_B in each cell, coloured by the governing constraint), and prints the table.

Grid (docs/theory.md, *Closure window*): h_W ∈ {1.0, 3.5} m; fall rate ∈ {0.30, 0.02} m/h; B ∈ {75, 25, 12} m; A_P ∈ {100, 500,
4000} ha; d_I ∈ {0.5, 1.5} m; Q_D = h_W B × 3 m/s.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import xarray as xr


def table_2_6() -> xr.Dataset:
    from breachflow.scenario import closure_window

    def axis(name, values, unit):
        return xr.DataArray(values, dims=name, coords={name: values}, attrs={"units": unit})

    return closure_window(
        surge_height=axis("surge_height", [1.0, 3.5], "m"),
        fall_rate=axis("fall_rate", [0.30, 0.02], "m/h"),
        breach_length=axis("breach_length", [75.0, 25.0, 12.0], "m"),
        mean_velocity="3 m/s",
        polder_area=axis("polder_area", [100.0, 500.0, 4000.0], "ha"),
        inundation_depth=axis("inundation_depth", [0.5, 1.5], "m"),
    )


def figure(ds: xr.Dataset, path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    from breachflow.scenario.io import atomic_path

    cw = ds["closure_window"].transpose("surge_height", "fall_rate", "breach_length", "polder_area", "inundation_depth")
    gov = ds["governing"].broadcast_like(cw).transpose(*cw.dims)
    tq = ds["balance_time"].broadcast_like(cw).transpose(*cw.dims)
    ti = ds["inundation_time"].broadcast_like(cw).transpose(*cw.dims)
    fig, axes = plt.subplots(2, 2, figsize=(14, 7.5), sharex=True)
    cmap = ListedColormap(["#9ecae1", "#a1d99b", "#dddddd"])
    col_labels = [f"{a / 1e4:g} ha\nd_I {d:g} m" for a in cw.polder_area.values for d in cw.inundation_depth.values]
    for i, h in enumerate(cw.surge_height.values):
        for j, f in enumerate(cw.fall_rate.values):
            ax = axes[i, j]
            g = gov.isel(surge_height=i, fall_rate=j).values.reshape(3, -1)
            ax.imshow(g, cmap=cmap, vmin=-0.5, vmax=2.5, aspect="auto")
            t_b = cw.isel(surge_height=i, fall_rate=j).values.reshape(3, -1) / 3600
            t_q = tq.isel(surge_height=i, fall_rate=j).values.reshape(3, -1) / 3600
            t_i = ti.isel(surge_height=i, fall_rate=j).values.reshape(3, -1) / 3600
            for r in range(t_b.shape[0]):
                for c in range(t_b.shape[1]):
                    ax.text(c, r - 0.12, f"{t_b[r, c]:.1f} h", ha="center", va="center", fontsize=10, weight="bold")
                    ax.text(c, r + 0.25, f"t_Q {t_q[r, c]:.1f} / t_I {t_i[r, c]:.1f}", ha="center", va="center",
                            fontsize=6.5, color="0.25")
            ax.set_yticks(range(3), [f"B = {b:g} m" for b in cw.breach_length.values])
            ax.set_xticks(range(len(col_labels)), col_labels, fontsize=8)
            kind = "rapid fall (hurricane)" if f > 0.1 / 3600 else "slow fall (riverine)"
            ax.set_title(f"h_W = {h:g} m, {kind}: {f * 3.6e5:g} cm/h", fontsize=10)
            for c in range(1, len(col_labels)):
                ax.axvline(c - 0.5, color="white", lw=2 if c % 2 == 0 else 0.5)
            for r in range(1, 3):
                ax.axhline(r - 0.5, color="white", lw=1)
    fig.legend(handles=[Patch(color="#9ecae1", label="breach balance time t_Q governs"),
                        Patch(color="#a1d99b", label="polder inundation time t_I governs")],
               loc="lower center", ncol=2, frameon=False)
    fig.suptitle("Breach closure window t_B (report Table 2.6 grid; Q_D = h_W B × 3 m/s, breach at the crest)")
    fig.tight_layout(rect=(0, 0.04, 1, 0.97))
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=130, format="png")
    plt.close(fig)
    return path


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("output_dir", type=Path, help="directory for table_2_6.nc and table_2_6.png")
    args = parser.parse_args(argv)
    from rich.console import Console

    from breachflow.scenario.io import write_netcdf
    from breachflow.scenario.report import window_grid_table

    ds = table_2_6()
    ds.attrs["title"] = "Breach closure windows, report Table 2.6 grid"
    args.output_dir.mkdir(parents=True, exist_ok=True)
    nc = write_netcdf(ds, args.output_dir / "table_2_6.nc")
    png = figure(ds, args.output_dir / "table_2_6.png")
    console = Console()
    console.print(window_grid_table(ds, title="Table 2.6 grid"))
    console.print(f"wrote {nc} and {png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
