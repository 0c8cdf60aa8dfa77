"""The atlas outputs: a CF NetCDF along ``location``, a GeoPackage of levee reaches and a feasibility map.

All three carry the CRS of the district's terrain. The GeoPackage is written with pyogrio (GDAL's OGR, the
library GIS programs read it with), one LineString feature per location: the levee reach from halfway to
the previous location to halfway to the next.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from ..atomic import atomic_path, atomic_write, atomic_write_netcdf
from .config import District
from .locations import Location
from .screening import FIELDS, feasibility_class

#: feasibility classes and their map colours
CLASSES = {"feasible": "#1a9850", "tight": "#fee08b", "not feasible": "#d73027", "not at risk": "#9e9e9e",
           "failed": "#000000"}
LAYER = "breach_atlas"
GEOMETRY = "breach_atlas"  #: the CF geometry container of atlas.nc (GDAL's layer name, as the GeoPackage's)


def build_dataset(district: District, locations: list[Location], records: list[dict]) -> xr.Dataset:
    """Every location's figures along ``location`` (CF: units, long names, the CRS as a grid mapping)."""
    n = len(locations)
    res = [r["result"] for r in records]
    data = {}
    for name, (units, long_name) in FIELDS.items():
        vals = np.array([float(r.get(name, np.nan)) for r in res], float)
        data[name] = ("location", vals, {"units": units, "long_name": long_name, "grid_mapping": "crs"})
    data["breach_chainage"] = ("location", np.array([loc.chainage for loc in locations]),
                               {"units": "m", "long_name": FIELDS["breach_chainage"][1]})
    for m in district.methods:
        data[f"duration_h_{m.name}"] = ("location", np.array([float(r.get(f"duration_h_{m.name}", np.nan)) for r in res]),
                                        {"units": "h", "long_name": f"closure duration by {m.name} "
                                                                     f"({m.capacity * 3.6:g} t/h)"})
        data[f"feasible_{m.name}"] = ("location", np.array([int(bool(r.get(f"feasible_{m.name}", False))) for r in res],
                                                           "i1"),
                                      {"long_name": f"closure by {m.name} ends within the closure window",
                                       "flag_values": np.array([0, 1], "i1"), "flag_meanings": "no yes"})
    classes = [feasibility_class(r) for r in res]
    names = list(CLASSES)
    data["feasibility"] = ("location", np.array([names.index(c) if c in names else names.index("failed")
                                                 for c in classes], "i1"),
                           {"long_name": "closure feasibility", "flag_values": np.arange(len(names), dtype="i1"),
                            "flag_meanings": " ".join(c.replace(" ", "_") for c in names)})
    best = [r.get("method", "") for r in res]
    data["method"] = ("location", np.array(best, dtype="S"), {"long_name": "fastest closure method that fits the "
                                                                          "window (else the fastest)"})
    data["message"] = ("location", np.array([r.get("message", "") or "" for r in res], dtype="S"),
                       {"long_name": "why a location is not screened or the caveat of its figures"})
    ds = xr.Dataset(data, coords={
        "location": ("location", np.arange(n, dtype="i4"), {"long_name": "candidate breach index", "units": "1"}),
        "x": ("location", np.array([loc.x for loc in locations]), {"units": "m", "standard_name": "projection_x_coordinate",
                                                                    "axis": "X", "long_name": "easting of the breach centre"}),
        "y": ("location", np.array([loc.y for loc in locations]), {"units": "m", "standard_name": "projection_y_coordinate",
                                                                    "axis": "Y", "long_name": "northing of the breach centre"}),
    })
    from .locations import load_inputs

    wkt = load_inputs(str(district.terrain), str(district.levee), district.crs, district.terrain_units)[0].crs_wkt
    ds["crs"] = xr.DataArray(np.int32(0), attrs=_grid_mapping(wkt))
    for v in ds.data_vars:
        if v != "crs" and "location" in ds[v].dims and ds[v].dtype.kind == "f":
            ds[v].attrs.setdefault("grid_mapping", "crs")
            ds[v].attrs["coordinates"] = "x y"
    ds.attrs = {"Conventions": "CF-1.8", "featureType": "point", "title": f"breach atlas: {district.name}",
                "summary": district.description, "source": "breachflow atlas (screening tier)",
                "flood_level_m": district.flood_level, "spacing_m": district.spacing,
                "methods": ", ".join(m.name for m in district.methods)}
    return ds


def point_geometry(ds: xr.Dataset) -> xr.Dataset:
    """*ds* with the locations declared as a CF-1.8 point geometry (CF §7.5): a geometry container whose
    node coordinates are ``x y``, named by every variable along ``location``. GDAL's netCDF driver reads a
    CF-1.8 file's geometry container as a vector layer (here: ``breach_atlas``, one point per location,
    every variable a field) with the CRS of ``crs``; xarray reads the file as before, plus the container."""
    ds = ds.copy()
    ds[GEOMETRY] = xr.DataArray(np.int32(0), attrs={"geometry_type": "point", "node_coordinates": "x y",
                                                    "grid_mapping": "crs",
                                                    "long_name": "candidate breach locations (points)"})
    for v in ds.data_vars:
        if v not in ("crs", GEOMETRY) and "location" in ds[v].dims:
            ds[v].attrs["geometry"] = GEOMETRY
            ds[v].attrs["grid_mapping"] = "crs"
    return ds


def _grid_mapping(wkt: str | None) -> dict:
    if not wkt:
        return {"grid_mapping_name": "unknown"}
    from pyproj import CRS

    attrs = CRS.from_wkt(wkt).to_cf()
    attrs["crs_wkt"] = wkt
    attrs["spatial_ref"] = wkt
    return attrs


def reach_lines(locations: list[Location], levee) -> list:
    """One LineString per location: the levee from halfway to its neighbours (the line's ends at the ends)."""
    import shapely
    from shapely.ops import substring

    s = np.array([loc.chainage for loc in locations])
    edges = np.concatenate([[0.0], 0.5 * (s[1:] + s[:-1]), [levee.length]])
    line = shapely.LineString(levee.coords)
    return [substring(line, float(a), float(b)) for a, b in zip(edges[:-1], edges[1:])]


def write_outputs(ds: xr.Dataset, district: District, locations: list[Location], out: Path) -> list[Path]:
    from .locations import load_inputs as _inputs

    terrain, levee = _inputs(str(district.terrain), str(district.levee), district.crs, district.terrain_units)
    lines = reach_lines(locations, levee)
    paths = [atomic_write_netcdf(point_geometry(ds), out / "atlas.nc")]
    paths.append(write_geopackage(ds, lines, out / "atlas.gpkg", terrain.crs_wkt))
    detailed = "p_closure" in ds and bool(np.isfinite(ds["p_closure"].values).any())
    title = f"{district.name}: closure feasibility" + (" (screening) and P(closure) (closure simulation)" if detailed
                                                       else " (screening)")
    paths.append(plot_map(ds, terrain, levee, lines, out / "atlas.png", title=title))
    return paths


def write_geopackage(ds: xr.Dataset, lines: list, path: Path, crs_wkt: str | None) -> Path:
    """The atlas as a GeoPackage layer ``breach_atlas`` of levee reaches (pyogrio)."""
    import pyogrio.raw
    import shapely

    fields, values = [], []
    for name in ["breach_chainage", *FIELDS.keys() - {"breach_chainage"}]:
        fields.append(name)
        values.append(ds[name].values.astype(float))
    for v in ds.data_vars:
        if v.startswith(("duration_h_", "feasible_")):
            fields.append(v)
            values.append(ds[v].values.astype(float if v.startswith("duration") else int))
    names = list(CLASSES)
    fields += ["feasibility", "method", "message"]
    values += [np.array([names[int(k)] for k in ds["feasibility"].values], object),
               np.array([m.decode() if isinstance(m, bytes) else str(m) for m in ds["method"].values], object),
               np.array([m.decode() if isinstance(m, bytes) else str(m) for m in ds["message"].values], object)]
    for name in ("p_closure", "p_closure_lower", "p_closure_upper", "tonnage_detailed_t_median",
                 "duration_detailed_h_median"):
        fields.append(name)  # NaN (null) where the detailed tier did not run
        values.append(ds[name].values.astype(float) if name in ds else np.full(ds.sizes["location"], np.nan))
    geoms = shapely.to_wkb(np.array(lines, dtype=object))
    with atomic_path(path) as tmp:
        pyogrio.raw.write(str(tmp), geoms, values, fields, layer=LAYER, driver="GPKG", geometry_type="LineString",
                          crs=crs_wkt)
    return path


#: colour map of P(closure) on the map (light: unlikely, dark: likely); distinct from the screening classes'
#: green-yellow-red and from the terrain's colours
P_CMAP = "Purples"


def plot_map(ds: xr.Dataset, terrain, levee, lines: list, path: Path, *, title: str = "") -> Path:
    """The map of :func:`render_map` as a PNG file."""
    import matplotlib.pyplot as plt

    fig = render_map(ds, terrain, lines, title=title)
    atomic_write(path, lambda tmp: fig.savefig(tmp, format="png"))
    plt.close(fig)
    return path


def render_map(ds: xr.Dataset, terrain, lines: list, *, title: str = ""):
    """The levee over a shaded terrain, in map coordinates (a matplotlib Figure): coloured by P(closure) where
    the detailed tier ran (a colour bar), by the screening's feasibility class elsewhere (thinner, a legend
    "screening only")."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.patheffects as pe
    import matplotlib.pyplot as plt
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import LightSource, Normalize
    from matplotlib.lines import Line2D
    from matplotlib.ticker import FuncFormatter

    names = list(CLASSES)
    x0, x1, y0, y1 = terrain.bounds
    pad = 0.03 * max(x1 - x0, y1 - y0)
    p = ds["p_closure"].values.astype(float) if "p_closure" in ds else np.full(ds.sizes["location"], np.nan)
    detailed = np.isfinite(p)
    fig, ax = plt.subplots(figsize=(11, 8), dpi=110, layout="constrained")
    z = np.ma.masked_invalid(terrain.z)
    shade = LightSource(azdeg=315, altdeg=45).hillshade(np.nan_to_num(terrain.z, nan=float(np.nanmin(terrain.z))),
                                                       vert_exag=20.0, dx=abs(terrain.x[1] - terrain.x[0]),
                                                       dy=abs(terrain.y[1] - terrain.y[0]))
    ax.imshow(shade, extent=(x0, x1, y0, y1), origin="lower", cmap="gray", alpha=0.6)
    im = ax.imshow(z, extent=(x0, x1, y0, y1), origin="lower", cmap="terrain", alpha=0.45)
    norm = Normalize(0.0, 1.0)
    from matplotlib.colors import ListedColormap

    pmap = ListedColormap(plt.get_cmap(P_CMAP)(np.linspace(0.2, 1.0, 256)), name="p_closure")  # no white at P = 0
    outline = [pe.Stroke(linewidth=9, foreground="black"), pe.Normal()]
    for line, k, pk, det in zip(lines, ds["feasibility"].values, p, detailed):
        xs, ys = line.xy
        if det:
            ax.plot(xs, ys, color=pmap(norm(pk)), lw=7, solid_capstyle="butt", path_effects=outline, zorder=4)
        else:
            ax.plot(xs, ys, color=CLASSES[names[int(k)]], lw=3.5, solid_capstyle="butt", zorder=3)
    ax.plot(ds.x.values, ds.y.values, "k.", ms=3, zorder=5)
    n = ds.sizes["location"]
    labelled = set(range(0, n, max(1, n // 10))) | set(np.flatnonzero(detailed).tolist())
    rank = {i: r for r, i in enumerate(np.flatnonzero(detailed))}
    for i in sorted(labelled):
        text = f"{ds.breach_chainage.values[i] / 1000:.1f} km"
        offset = (6, 6)
        if detailed[i]:
            text += f"\nP = {p[i]:.2f}"
            offset = (10, 8) if rank[i] % 2 == 0 else (-12, -30)  # neighbours' labels on opposite sides
        ax.annotate(text, (ds.x.values[i], ds.y.values[i]), xytext=offset, textcoords="offset points", fontsize=8,
                    fontweight="bold" if detailed[i] else "normal", zorder=6,
                    bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.7) if detailed[i] else None)
    handles = [Line2D([], [], color=c, lw=3.5, label=f"{name} ({int(np.sum((ds.feasibility.values == i) & ~detailed))})")
               for i, (name, c) in enumerate(CLASSES.items())]
    if detailed.any():
        handles.append(Line2D([], [], color=pmap(0.6), lw=7, path_effects=outline,
                              label=f"closure simulated ({int(detailed.sum())}): P(closure), colour bar"))
    ax.legend(handles=handles, loc="best", fontsize=9,
              title="screening only: closure feasibility" if detailed.any() else "closure feasibility (screening)")
    fmt = FuncFormatter(lambda v, _: f"{v:,.0f}")
    ax.xaxis.set_major_formatter(fmt)
    ax.yaxis.set_major_formatter(fmt)
    ax.set_xlim(x0 - pad, x1 + pad)
    ax.set_ylim(y0 - pad, y1 + pad)
    ax.set_aspect("equal")
    ax.set_xlabel("easting (m)")
    ax.set_ylabel("northing (m)")
    ax.set_title(title, fontsize=11, wrap=True)
    if detailed.any():
        fig.colorbar(ScalarMappable(norm=norm, cmap=pmap), ax=ax, shrink=0.6, pad=0.01,
                     label="P(closure) of the closure simulation (replicates)")
    fig.colorbar(im, ax=ax, label="ground elevation (m)", shrink=0.6, pad=0.01)
    return fig
