"""The report's settling-sphere validation (docs/validation.md, *Settling spheres*, report §5 Fig 5.2), reproducible from one call.

Steel spheres (7800 kg/m^3) of 3, 10 and 80 mm released from rest just under the surface of still water
(Lyotard et al. 2007), velocity against time over 0–1 s, DEM with the report's integrator, dt = 1e-5 s,
no global damping, apparent mass 0.5.  The 80 mm sphere reaches Reynolds numbers of 1e5–4e5, where the
drag law decides the result: with the report's Table 3.2 (drag crisis at ``R ~ 3e5``) it keeps
accelerating where a law without the crisis (Clift–Gauvin) has reached its terminal velocity.

:func:`settling_curves` returns an xarray Dataset (dims ``drag_law``, ``diameter``, ``time``);
:func:`save_settling` writes it as NetCDF and CSV plus a PNG plot, atomically.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import xarray as xr
from scipy.optimize import brentq

from ..errors import InputError
from ..atomic import atomic_write
from ..fluid.drag import DRAG_LAWS
from ..fluid.field import UniformWater
from ..fluid.forces import WATER, FluidForces

FIG52_DIAMETERS = (0.003, 0.010, 0.080)
STEEL = 7800.0


def terminal_velocity(diameter: float, density: float, drag_law="report", fluid=WATER, gravity: float = 9.80665) -> float:
    """Root ``v`` of ``(rho_S - rho_F) V g = 1/2 C_D(v D / nu) rho_F A v^2`` (m/s).

    With a law that has a drag crisis the force balance can have several roots; the smallest is returned
    (the one a sphere accelerating from rest meets first).
    """
    law = DRAG_LAWS.create(drag_law)
    d = float(diameter)
    if not (d > 0 and density > fluid.rho):
        raise InputError(f"terminal_velocity: need diameter > 0 and density > {fluid.rho} kg/m^3")
    vol, area = math.pi * d**3 / 6, math.pi * d * d / 4
    weight = (density - fluid.rho) * vol * gravity
    balance = lambda v: weight - 0.5 * law.cd_re(v * d / fluid.nu) * fluid.nu / d * fluid.rho * area * v  # noqa: E731
    v = np.geomspace(1e-9, 1e3, 4000)
    f = np.array([balance(x) for x in v])
    k = int(np.flatnonzero(f <= 0)[0])
    if f[k] == 0.0:
        return float(v[k])
    return brentq(balance, v[k - 1], v[k], xtol=1e-15, rtol=1e-14)


def settling_curves(diameters=FIG52_DIAMETERS, density: float = STEEL, drag_laws=("report",), *, dt: float = 1e-5,
                    duration: float = 1.0, integrator: str = "report", xi: float = 0.5, record_every: float = 1e-3,
                    fluid=WATER, progress=None) -> xr.Dataset:
    """Velocity–time curves of spheres settling from rest in still water (docs/validation.md, *Settling spheres*).

    All diameters of one drag law run together in one DEM simulation (spheres far apart, no contacts);
    ``integrator`` is a DEM integrator name (``report``, ``velocity_verlet``, ...) stepping ``dt``, or a
    free-flight method (``dopri5``, ``bs32``: adaptive; ``rk4``: fixed ``dt``).  Global damping is zero.
    Returns ``velocity`` (downward, m/s), ``depth`` (of the centre below the release point, m),
    ``reynolds`` and ``cd`` along the curves, and the ``terminal_velocity`` of each law by root solve.
    """
    from ..dem import DemSimulation, Gravity, Material, ParticleState
    from ..fluid.freeflight import TABLEAUX, integrate

    diameters = np.atleast_1d(np.asarray(diameters, dtype=float))
    if np.any(~(diameters > 0)) or not (duration > 0 and dt > 0 and record_every >= dt):
        raise InputError("settling_curves: diameters, duration, dt > 0 and record_every >= dt are required")
    laws = [DRAG_LAWS.create(x) for x in drag_laws]
    n_rec = int(round(duration / record_every))
    times = np.arange(n_rec + 1) * record_every
    vel = np.zeros((len(laws), diameters.size, n_rec + 1))
    dep = np.zeros_like(vel)
    spacing = 10.0 * diameters.max()
    pos = np.array([[k * spacing, 0.0, -diameters[k] / 2 - 1e-9] for k in range(diameters.size)])
    for j, law in enumerate(laws):
        state = ParticleState.empty()
        for k, d in enumerate(diameters):  # soft contact stiffness: no contacts here, dt is free
            state.add(pos[k:k + 1], d / 2, Material(density=density, kn=1e-6, c_gn=0.0, c_gw=0.0))
        model = FluidForces(UniformWater(surface=0.0), drag_law=law, water=fluid, xi=xi, velocity_profile="uniform")
        if integrator in TABLEAUX:
            adaptive = integrator in ("dopri5", "bs32")
            res = integrate(state, [Gravity(), model], times, method=integrator, dt=None if adaptive else dt,
                            rtol=1e-8, atol=1e-11)
            vel[j] = -res.vel[:, :, 2].T
            dep[j] = (pos[:, 2][None, :] - res.pos[:, :, 2]).T
        else:
            sim = DemSimulation(state, models=[model], integrator=integrator, dt=dt, sleeping=False)
            per = int(round(record_every / dt))
            for r in range(1, n_rec + 1):
                sim.step(per)
                vel[j, :, r] = -state.vel[:, 2]
                dep[j, :, r] = pos[:, 2] - state.pos[:, 2]
                if progress is not None:
                    progress(j, r, n_rec)
    reynolds = np.abs(vel) * diameters[None, :, None] / fluid.nu
    cd = np.stack([law.cd(np.maximum(reynolds[j], 1e-12)) for j, law in enumerate(laws)])
    v_t = np.array([[terminal_velocity(d, density, law, fluid) for d in diameters] for law in laws])
    ds = xr.Dataset(
        {
            "velocity": (("drag_law", "diameter", "time"), vel, {"long_name": "settling velocity (downward)", "units": "m s-1"}),
            "depth": (("drag_law", "diameter", "time"), dep, {"long_name": "centre depth below release point", "units": "m"}),
            "reynolds": (("drag_law", "diameter", "time"), reynolds, {"long_name": "particle Reynolds number", "units": "1"}),
            "cd": (("drag_law", "diameter", "time"), cd, {"long_name": "drag coefficient along the curve", "units": "1"}),
            "terminal_velocity": (("drag_law", "diameter"), v_t, {"long_name": "terminal velocity, root of the force balance", "units": "m s-1"}),
        },
        coords={
            "drag_law": ("drag_law", [law.name for law in laws], {"long_name": "drag law of the curve"}),
            "diameter": ("diameter", diameters, {"long_name": "sphere diameter", "units": "m"}),
            "time": ("time", times, {"long_name": "time since release from rest", "units": "s"}),
        },
        attrs={
            "Conventions": "CF-1.8",
            "title": "Spheres settling from rest in still water (report Fig 5.2, docs/validation.md, Settling spheres)",
            "particle_density_kg_m3": float(density), "fluid_density_kg_m3": fluid.rho,
            "fluid_kinematic_viscosity_m2_s": fluid.nu, "apparent_mass_coefficient": float(xi),
            "integrator": integrator, "time_step_s": float(dt), "global_damping": 0.0,
        },
    )
    return ds


def drag_crisis_time(ds: xr.Dataset, law: str, diameter: float, cd_below: float = 0.3) -> float | None:
    """First time (s) the drag coefficient along a curve falls below *cd_below* (None if never)."""
    cd = ds["cd"].sel(drag_law=law).sel(diameter=diameter, method="nearest").values
    hit = np.flatnonzero(cd < cd_below)
    return float(ds["time"].values[hit[0]]) if hit.size else None


def plot_settling(ds: xr.Dataset, path) -> Path:
    """Velocity–time plot, one colour per diameter, one line style per drag law; PNG written atomically."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    styles = ["-", "--", ":", "-."]
    fig, ax = plt.subplots(figsize=(7.5, 5.0), dpi=120)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for k, d in enumerate(ds["diameter"].values):
        for j, law in enumerate(ds["drag_law"].values):
            ax.plot(ds["time"], ds["velocity"].isel(drag_law=j, diameter=k), styles[j % 4], color=colours[k % 10],
                    label=f"{d * 1e3:g} mm, {law}")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("settling velocity (m/s)")
    ax.set_title(f"Steel spheres from rest in still water (dt = {ds.attrs['time_step_s']:g} s, "
                 f"{ds.attrs['integrator']}, no global damping)", fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, ncol=2)
    fig.tight_layout()
    path = Path(path)
    atomic_write(path, lambda tmp: fig.savefig(tmp, format="png"))
    plt.close(fig)
    return path


def save_settling(ds: xr.Dataset, out_dir, stem: str = "settling") -> dict[str, Path]:
    """Write ``<stem>.nc``, ``<stem>.csv`` (long format) and ``<stem>.png`` into *out_dir*; returns the paths."""
    out = Path(out_dir)
    paths = {"netcdf": out / f"{stem}.nc", "csv": out / f"{stem}.csv", "png": out / f"{stem}.png"}
    from ..provenance import stamp

    from ..io.cf import cf_text_coordinates, string_encoding

    disk = cf_text_coordinates(stamp(ds))
    atomic_write(paths["netcdf"], lambda tmp: disk.to_netcdf(tmp, encoding=string_encoding(disk)))
    table = ds[["velocity", "depth", "reynolds", "cd"]].to_dataframe().reset_index()
    atomic_write(paths["csv"], lambda tmp: table.to_csv(tmp, index=False, float_format="%.9g"))
    plot_settling(ds, paths["png"])
    return paths
