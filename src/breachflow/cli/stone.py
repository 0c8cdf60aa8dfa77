"""``breachflow stone-size``: Izbash/Shields stone size and the rock to fill a breach (no simulation)."""
from __future__ import annotations

import typer


def register(app: typer.Typer) -> None:
    @app.command("stone-size")
    def stone_size_cmd(
        velocity: str = typer.Option(..., help="design flow velocity in the gap, e.g. '4 m/s'"),
        depth: str = typer.Option(..., help="water depth in the gap, e.g. '3 m'"),
        breach_length: str = typer.Option(..., help="breach length (bottom width), e.g. '12 m'"),
        breach_depth: str = typer.Option(None, help="height of the dam to build (default: depth)"),
        density: str = typer.Option("2650 kg/m^3", help="rock density"),
        porosity: float = typer.Option(None, help="porosity of the dumped pile (default 0.40, as [placement] porosity)"),
        side_slope: float = typer.Option(None, help="pile side slopes, H per V (default 1.5: 1V:1.5H, as [placement] side_slope)"),
        crest_width: str = typer.Option(None, help="crest width (default max(3 D, 1 m))"),
        wall_slope: float = typer.Option(None, help="breach wall slope, H per V (0 = vertical; default the breach's default, 1V:0.5H as [breach] wall_slope)"),
        theta_c: float = typer.Option(0.047, help="critical Shields parameter"),
    ) -> None:
        """Stone diameter by Izbash (exposed 0.86 / embedded 1.2) and Shields, rock volume and tonnage."""
        from rich.table import Table

        from ..scenario.stone import stone_size
        from ._common import console

        # stone_size's defaults where an option is not given
        walls = {k: v for k, v in (("wall_slope", wall_slope), ("porosity", porosity), ("side_slope", side_slope))
                 if v is not None}
        e = stone_size(velocity, depth, breach_length, breach_depth=breach_depth, density=density,
                       crest_width=crest_width, theta_c=theta_c, **walls)
        t = Table(title=f"stone size for U = {e.velocity:.2f} m/s, h = {e.depth:.2f} m")
        t.add_column("quantity")
        t.add_column("value", justify="right")
        for name, val in (("D Izbash exposed (m)", f"{e.d_izbash_exposed:.3f}"),
                          ("D Izbash embedded (m)", f"{e.d_izbash_embedded:.3f}"),
                          (f"D Shields theta_c={theta_c:g} (m)", f"{e.d_shields:.3f}"),
                          ("design D (m)", f"{e.design_diameter:.3f}"),
                          ("stone mass (t)", f"{e.stone_mass / 1000:.3f}"),
                          ("dam height x crest (m)", f"{e.height:.2f} x {e.crest_width:.2f}"),
                          ("bulk volume (m^3)", f"{e.bulk_volume:.1f}"),
                          (f"rock volume, porosity {e.porosity:g} (m^3)", f"{e.rock_volume:.1f}"),
                          ("tonnage (t)", f"{e.tonnage:.1f}")):
            t.add_row(name, val)
        console().print(t)
