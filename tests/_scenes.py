"""Scene text shared by tests in several folders, each defined once."""

#: the scenario of one cheap closure member (the README's tiny ensemble, the closure runner's pair): the
#: default scene's breach on 2 m cells in a small domain, first-order flow, short DEM cycles, 3 masses a
#: cycle, at most 2 cycles
TINY_CLOSURE_MEMBER = """[flood]
surge_height = "3 m"
fall_rate = "0.3 m/hr"
[polder]
area = "100 ha"
inundation_depth = "1.5 m"
[breach]
length = "12 m"
depth = "3 m"
wall_slope = 0
[site]
preset = "demo_breach"
levee_length_each_side = "16 m"
flood_side_extent = "20 m"
protected_side_extent = "20 m"
[hydro]
resolution = "2 m"
order = 1
t_max_initial = "60 s"
t_max = "20 s"
monitor_radius = "10 m"
[dem]
max_time = "3 s"
[placement]
batch = 3
[criteria]
max_cycles = 2
max_speed = "0.05 m/s"
"""

#: ``[site]`` of the default scene's breach (12 m in a 3 m levee) in a domain larger than the default: 54 m
#: of levee each side, 60 m of flood side, 48 m of polder
LARGE_DEMO_SITE = """[site]
preset = "demo_breach"
levee_length_each_side = "54 m"
flood_side_extent = "60 m"
protected_side_extent = "48 m"
"""
