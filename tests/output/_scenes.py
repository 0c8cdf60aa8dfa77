"""The small closure scene the output tests write their files from: the demo breach at 2 m cells, first-order
flow, short DEM cycles and two rock sizes dropped in pairs along the breach; closed only when the flow nearly
stops (``max_speed`` 0.01 m/s), so a run goes on for its ``max_cycles``."""


def tiny_closure(name: str, *, max_cycles: int, crs: str | None = None, density: str | None = None,
                 max_speed: str = '"0.01 m/s"') -> str:
    """Scenario TOML of the scene; *crs* adds ``[site] crs``, *density* ``[placement] density``, *max_speed*
    is the criterion's TOML value (a quantity string or an inline table)."""
    crs_line = f'crs = "{crs}"\n' if crs else ""
    density_line = f'density = "{density}"\n' if density else ""
    return f"""
[scenario]
name = "{name}"
[site]
preset = "demo_breach"
{crs_line}levee_length_each_side = "12 m"
flood_side_extent = "14 m"
protected_side_extent = "14 m"
[hydro]
resolution = "2 m"
order = 1
t_max_initial = "30 s"
t_max = "10 s"
monitor_radius = "8 m"
[dem]
max_time = "1.5 s"
record_interval = "0.25 s"
[placement]
diameter = ["1.6 m", "2.0 m"]
{density_line}batch = 2
positions = "line"
start = ["-3 m", "0 m"]
stop = ["3 m", "0 m"]
release_height = "0.5 m"
[criteria]
max_cycles = {max_cycles}
max_speed = {max_speed}
[closure]
remap = "raised_bed"
seed = 2
"""
