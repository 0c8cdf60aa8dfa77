"""CF-1.8 Datasets for what a closure run writes: particle states and particle trajectories.

Particle states at equilibrium are plain variables along a ``particle`` dimension (they share a file
with the cycle's hydrodynamic grid). Trajectories of the moving particles of a cycle are a CF
discrete sampling geometry, ``featureType = "trajectory"``, in the multidimensional array
representation (CF §H.4.1): dims ``(trajectory, obs)``, ``trajectory_id`` with ``cf_role``, and
``time``/``x``/``y``/``z`` as coordinates, unused observations filled with ``_FillValue``.
"""
from __future__ import annotations

import numpy as np
import xarray as xr

#: Trajectory time: a relative axis, seconds since the cycle's masses were released (no calendar date:
#: the closure operation has none; the cycle's start on the operation clock is the attribute
#: ``cycle_start_time`` of the file)
TIME_UNITS = "s"
TIME_ATTRS = {"long_name": "time since the start of the cycle (release of its masses)", "axis": "T"}

_POS_ATTRS = (
    {"long_name": "particle centre x coordinate", "units": "m"},
    {"long_name": "particle centre y coordinate", "units": "m"},
    {"standard_name": "altitude", "long_name": "particle centre elevation above datum", "units": "m", "positive": "up"},
)


#: per-particle coefficients each mass carries from its material (name in the state → variable attributes);
#: NaN where the mass takes the run's drag law (not a constant) or lift term; the apparent-mass coefficient is
#: its material's or the run's ``[fluid] xi``
_COEFFICIENT_ATTRS = {
    "drag_coefficient": {"long_name": "particle drag coefficient (Newton regime) of its material's shape",
                         "units": "1", "comment": "NaN: the run's drag law ([fluid] drag_law), where it is not a constant C_D"},
    "lift_coefficient": {"long_name": "particle lift coefficient of its material", "units": "1",
                         "comment": "NaN: the run's lift term"},
    "added_mass_coefficient": {"long_name": "particle apparent (added) mass coefficient xi (its material's or [fluid] xi)",
                               "units": "1"},
    "friction": {"long_name": "particle Coulomb friction coefficient", "units": "1"},
    "rolling_friction": {"long_name": "particle rolling resistance coefficient", "units": "1"},
}


def _flag_word(name: str) -> str:
    """A material name as one blank-free word of ``flag_meanings`` (CF §3.5)."""
    import re

    return re.sub(r"[^A-Za-z0-9_.+-]", "_", str(name)) or "unnamed"


def particles_dataset(state, *, placed_cycle, particle_id=None, resting=None, grid_mapping: str | None = None,
                      material=None, material_names=None, run_drag_coefficient=None,
                      run_added_mass_coefficient=None) -> xr.Dataset:
    """Particle states (positions, velocities, sizes, masses) along dim ``particle``.

    *state* is a :class:`breachflow.dem.state.ParticleState`; ``placed_cycle`` the cycle ``<g>`` in
    which each particle was released; ``resting`` whether it counts as resting at equilibrium. The
    coefficients each mass carries (drag, lift, apparent mass, friction, rolling resistance) are written per
    particle; with *material* (each particle's index into *material_names*) also ``particle_material``, a
    flag variable naming each mass's material (``flag_values`` / ``flag_meanings``). With
    *run_drag_coefficient* (the run's drag law is a constant C_D) a mass without its own drag coefficient is
    written with that value, the one it moved with; likewise *run_added_mass_coefficient* (the run's xi) for a
    mass without its own apparent-mass coefficient.
    """
    n = state.n
    pid = np.arange(n, dtype="i4") if particle_id is None else np.asarray(particle_id, dtype="i4")
    ds = xr.Dataset(coords={"particle": ("particle", pid, {"long_name": "particle index", "units": "1"})})
    for k, attrs in enumerate(_POS_ATTRS):
        name = "xyz"[k]
        a = dict(attrs)
        if grid_mapping and k < 2:
            a["grid_mapping"] = grid_mapping
        ds[f"particle_{name}"] = ("particle", state.pos[:, k].astype(float), a)
    for k, name in enumerate("xyz"):
        ds[f"particle_velocity_{name}"] = ("particle", state.vel[:, k].astype(float),
                                           {"long_name": f"particle velocity, {name} component", "units": "m s-1"})
    ds["particle_diameter"] = ("particle", 2.0 * state.radius, {"long_name": "particle (mass) diameter", "units": "m"})
    ds["particle_density"] = ("particle", state.density.astype(float), {"long_name": "particle material density", "units": "kg m-3"})
    ds["particle_mass"] = ("particle", state.mass.astype(float), {"long_name": "particle mass", "units": "kg"})
    ds["particle_placed_cycle"] = ("particle", np.asarray(placed_cycle, dtype="i4"),
                                   {"long_name": "cycle <g> in which the particle was released", "units": "1"})
    ds["particle_active"] = ("particle", state.active.astype("i1"),
                             {"long_name": "particle inside the domain", "units": "1",
                              "flag_values": np.array([0, 1], "i1"), "flag_meanings": "left_domain inside"})
    for name, attrs in _COEFFICIENT_ATTRS.items():
        vals = getattr(state, name, None)
        if vals is not None:
            vals = np.asarray(vals, float)[:n].copy()
            run = {"drag_coefficient": run_drag_coefficient, "added_mass_coefficient": run_added_mass_coefficient}
            if run.get(name) is not None:
                vals[np.isnan(vals)] = float(run[name])
            ds[f"particle_{name}"] = ("particle", vals, dict(attrs))
    if material is not None:
        names = [_flag_word(m) for m in (material_names or ["sphere"])]
        ds["particle_material"] = ("particle", np.asarray(material).astype("i1"),
                                   {"long_name": "closure material of the particle", "units": "1",
                                    "flag_values": np.arange(len(names), dtype="i1"), "flag_meanings": " ".join(names)})
    if resting is not None:
        ds["particle_resting"] = ("particle", np.asarray(resting).astype("i1"),
                                  {"long_name": "particle at rest (remapped as an obstruction)", "units": "1",
                                   "flag_values": np.array([0, 1], "i1"), "flag_meanings": "moving resting"})
    return ds


def pad_particles(ds: xr.Dataset, capacity: int) -> xr.Dataset:
    """Pad the ``particle`` dimension of a :func:`particles_dataset` to *capacity* entries (the run's most
    masses, ``max_cycles × batch``), so that every cycle file of a run has the same ``particle`` index
    and the cycles stack with ``xr.open_mfdataset``. Unplaced entries: NaN, ``particle_placed_cycle`` 0,
    ``particle_active`` / ``particle_resting`` -1 (flag ``not_placed``)."""
    n = ds.sizes["particle"]
    if capacity < n:
        raise ValueError(f"particle capacity {capacity} < {n} particles")
    out = {}
    for name, da in ds.data_vars.items():
        if "particle" not in da.dims:
            continue
        fill = {"particle_placed_cycle": 0}.get(name, -1 if da.dtype.kind in "iu" else np.nan)
        data = np.concatenate([da.values, np.full(capacity - n, fill, da.dtype)])
        attrs = dict(da.attrs)
        if "flag_values" in attrs and -1 not in attrs["flag_values"]:
            attrs["flag_values"] = np.concatenate([np.array([-1], "i1"), attrs["flag_values"]])
            attrs["flag_meanings"] = "not_placed " + attrs["flag_meanings"]
        if name == "particle_placed_cycle":
            attrs["comment"] = "0: not placed yet"
        out[name] = ("particle", data, attrs)
    pid = np.arange(capacity, dtype="i4")
    padded = xr.Dataset(out, coords={"particle": ("particle", pid, dict(ds.particle.attrs))})
    return padded.assign(**{k: v for k, v in ds.data_vars.items() if "particle" not in v.dims})


def trajectories_dataset(trajectory_id, time, pos, vel=None, *, cycle: int, cycle_start: float = 0.0,
                         title: str = "") -> xr.Dataset:
    """CF trajectory DSG from ``time`` (n_traj, n_obs) s since the start of the cycle and ``pos``
    (n_traj, n_obs, 3) m; *cycle_start* is that start on the closure operation's clock (s). With ``vel``
    (n_traj, n_obs, 3) m/s: the speed and the velocity components along the trajectories.

    NaN marks observations past the end of a trajectory (they become ``_FillValue`` on write).
    """
    time = np.asarray(time, dtype=float)
    pos = np.asarray(pos, dtype=float)
    ntraj, nobs = time.shape
    ds = xr.Dataset(
        coords={
            "time": (("trajectory", "obs"), time, {**TIME_ATTRS, "units": TIME_UNITS}),
            "x": (("trajectory", "obs"), pos[..., 0], {"long_name": "particle centre x coordinate", "units": "m"}),
            "y": (("trajectory", "obs"), pos[..., 1], {"long_name": "particle centre y coordinate", "units": "m"}),
            "z": (("trajectory", "obs"), pos[..., 2], {"standard_name": "altitude", "long_name": "particle centre elevation",
                                                      "units": "m", "positive": "up", "axis": "Z"}),
        },
    )
    ds["trajectory_id"] = ("trajectory", np.asarray(trajectory_id, dtype="i4"),
                           {"cf_role": "trajectory_id", "long_name": "particle index"})
    if vel is not None:
        vel = np.asarray(vel, dtype=float)
        speed = np.sqrt(np.sum(vel**2, axis=-1))
        ds["speed"] = (("trajectory", "obs"), speed, {"long_name": "particle speed", "units": "m s-1",
                                                     "coordinates": "time x y z"})
        for k, name in enumerate("xyz"):
            ds[f"velocity_{name}"] = (("trajectory", "obs"), vel[..., k],
                                      {"long_name": f"particle velocity, {name} component", "units": "m s-1",
                                       "coordinates": "time x y z"})
    else:
        ds["elevation"] = (("trajectory", "obs"), pos[..., 2], {"long_name": "particle centre elevation", "units": "m",
                                                                "coordinates": "time x y z"})
    ds.attrs.update(Conventions="CF-1.8", featureType="trajectory",
                    title=title or f"breachflow trajectories of the moving particles in cycle {cycle}",
                    cycle=np.int32(cycle), cycle_start_time=float(cycle_start),
                    cycle_start_time_units="s on the closure operation clock (masses placed / placement rate)")
    return ds


def string_encoding(ds: xr.Dataset) -> dict:
    """Encoding that writes the text variables of *ds* as CF character arrays (dimension ``<name>_strlen``,
    UTF-8) rather than NetCDF-4 variable-length strings, which the CF checker (CF-1.8) and GDAL's classic
    netCDF driver do not accept. Merge it into a writer's encoding."""
    enc = {}
    for name, da in ds.variables.items():
        if da.dtype.kind in "OUS":
            enc[name] = {"dtype": "S1", "char_dim_name": f"{name}_strlen", "_FillValue": None}
            if da.dtype.kind != "S":
                enc[name]["_Encoding"] = "utf-8"
    return enc


def netcdf_encoding(ds: xr.Dataset) -> dict:
    """Encoding that writes NaN as ``_FillValue`` for float variables and none for integer ones, and text
    as CF character arrays (:func:`string_encoding`)."""
    enc = string_encoding(ds)
    for name, da in ds.variables.items():
        if name in enc:
            continue
        if np.issubdtype(da.dtype, np.floating) and name not in ds.dims:
            enc[name] = {"_FillValue": np.nan}
        elif name in ds.dims or not np.issubdtype(da.dtype, np.floating):
            enc[name] = {"_FillValue": None}
    return enc


#: suffix of the auxiliary coordinate holding the text labels of an indexed dimension (:func:`cf_text_coordinates`)
LABEL_SUFFIX = "_label"


def cf_text_coordinates(ds: xr.Dataset) -> xr.Dataset:
    """*ds* with every text dimension coordinate (``drag_law = ["report", ...]``) turned into the CF form
    the checkers accept: an integer index coordinate of the same name and the labels in the auxiliary
    coordinate ``<name>_label`` (a character array). :func:`restore_text_coordinates` undoes it."""
    for name in list(ds.dims):
        if name in ds.coords and ds[name].dtype.kind in "OUS":
            attrs = dict(ds[name].attrs)
            labels = np.asarray(ds[name].values).astype(str)
            ds = ds.assign_coords({name: (name, np.arange(labels.size, dtype="i4"),
                                          {"long_name": f"index of {attrs.get('long_name', name)}", "units": "1"})})
            ds = ds.assign_coords({name + LABEL_SUFFIX: (name, labels, {**attrs, "long_name": attrs.get("long_name", name)})})
    return ds


def restore_text_coordinates(ds: xr.Dataset) -> xr.Dataset:
    """Undo :func:`cf_text_coordinates`: the labels of ``<name>_label`` back as the dimension coordinate."""
    for name in list(ds.dims):
        lab = name + LABEL_SUFFIX
        if lab in ds.coords and ds[lab].dims == (name,):
            attrs = dict(ds[lab].attrs)
            ds = ds.drop_vars(lab).assign_coords({name: (name, np.asarray(ds[lab].values).astype(str), attrs)})
    return ds
