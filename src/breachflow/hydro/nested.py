"""A local shallow-water model nested in an ingested regional field (issue 13; docs/theory.md, *Shallow-water equations*, *The closure cycle* cycle <g>).

The regional field is an ingested snapshot (ADH/SMS mesh, HEC-RAS sdf or HDF mesh, ESRI grid, or a
grid snapshot of our own solver). Around the breach a local structured-grid model is built from it:

* terrain: from its finest source when one is given (``terrain``: the analytic geometry of a preset or
  scene, or a site's terrain file, at the local cells — a nested grid of a closure's own coarse solve,
  ``[hydro] refine``, always has one), else the regional bed interpolated at the local cell centres
  (bilinear on grids, barycentric on triangles — :class:`~breachflow.field.sampling.FieldSampler`); cells outside the regional field (mesh
  holes such as an intact levee modelled as no-flow, or the regional model's obstacle cells) are local
  obstacles; a grid without an obstacle mask (ESRI grids: the levee is dry terrain) gets one from its
  dry cells that the wet cells' water surface would flood (:mod:`~breachflow.hydro.regional_grid`);
* initial state: the regional depth and velocity there;
* boundary conditions, per edge cell, from the regional field: where water enters, the regional water
  level (supercritical inflow: level and unit discharge); where it leaves, free outflow (``leaving =
  "free"``, the default: a level held where the open breach's jet left would keep the polder at the
  open-breach state and drive water back in once the pile shuts the breach) or, with ``leaving =
  "level"``, the regional level where it leaves subcritically; dry edge cells free outflow; outside the
  regional field, wall. On the flood side of the levee (``flood_side``, :func:`levee_side`) water that
  leaves subcritically keeps the regional level whatever *leaving* says: the flood channel beyond the box
  is a water body whose level the regional field sets, and a free outflow there lets it drain out of the
  box (a slow drift of 0.1 m/s along the channel made the typical breach's flood side run out of its nested
  box at 5-6 m/s, 2 m below the flood, once the polder's level was put on the free outflows). The
  levels are absorbing (relaxation ``4 L / sqrt(g h_max)``, L the box size, as the typical breach's
  flood source): an exact level reflects every wave and the local basin would ring;
* the nested box (:func:`breach_box`): the breach ± (B/2 + 3 B) along the levee and ± 3 B across, its
  cells sized ``B / round(B / resolution)`` so that the breach ends fall on cell faces (the breach width
  is then exact on the local grid whatever the regional mesh);
* a levee in any direction: with a *frame* (:class:`~breachflow.site.frame.GridFrame` of a terrain site, the
  CRS rotated about the breach centre by the levee's direction there) the local grid is built in the
  breach-aligned grid coordinates, the regional field is sampled at the cells' map positions
  ``c + R(θ)(x − c)`` and its velocity turned into grid components ``R(−θ) (u_east, v_north)``
  (:class:`FramedSampler`: the same for the local model's terrain, initial state, edges, and for the DEM's
  fallback); the snapshots carry their map coordinates (:meth:`~breachflow.site.frame.GridFrame.georeference`).

Each ``solve`` re-solves the local model to steady state with the pile (obstacles / raised bed) from
the previous state; outside the nested box the regional field stays as ingested. The snapshots it
returns are the local grid with ``hydro_mode = "nested"``; the DEM samples the local field where it
exists and the regional one outside the box (:meth:`NestedSolver.fallback_sampler`, the
``fallback`` of :class:`~breachflow.field.sampling.FieldSampler`).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from ..errors import InputError
from .regional_grid import with_no_flow
from ..field.sampling import FieldSample, FieldSampler
from ..field.snapshot import DRY_DEPTH
from ..swe.domain import BoundaryCondition, Domain, uniform_grid
from ..swe.solver import WINDOW_CHANGE

GRAVITY = 9.81


#: suffixes of snapshot NetCDF files (``breachflow ingest`` output); any other file is a model export
NETCDF_SUFFIXES = (".nc", ".nc4", ".netcdf", ".cdf")


def load_regional(snapshots) -> xr.Dataset:
    """One regional snapshot from a Dataset / NetCDF path / list of them (a time series: its last step),
    or from model export files that together form one snapshot (ADH/SMS ``.3dm`` + ``.dat`` + ``.bc``,
    a HEC-RAS ``.sdf`` or 6.x plan ``.hdf``, ESRI grids), read with
    :func:`~breachflow.io.open_snapshot` (format from the extensions, units from the files)."""
    items = list(snapshots) if isinstance(snapshots, (list, tuple)) else [snapshots]
    if not items:
        raise InputError("nested solver: give the ingested regional snapshot (snapshots = [file])")
    exports = [p for p in items if isinstance(p, (str, Path)) and Path(p).suffix.lower() not in NETCDF_SUFFIXES]
    if exports:
        if len(exports) != len(items):
            raise InputError("nested solver: snapshots = [...] mixes snapshot NetCDF files and model export files "
                             f"({', '.join(map(str, exports))}); give one or the other")
        from ..io import open_snapshot

        ds = open_snapshot(exports)
        ds.attrs.setdefault("source", ", ".join(Path(p).name for p in exports))
        items = [ds]
    item = items[-1]
    if isinstance(item, (str, Path)):
        if not Path(item).exists():
            raise InputError(f"nested solver: regional snapshot not found: {item}")
        ds = xr.open_dataset(item).load()
    elif isinstance(item, xr.Dataset):
        ds = item
    else:
        raise InputError(f"nested solver: {item!r} is not a Dataset or a NetCDF path")
    if "time" in ds.dims:
        ds = ds.isel(time=-1)
    for v in ("bed_elevation", "depth", "u", "v"):
        if v not in ds:
            raise InputError(f"nested solver: the regional snapshot has no {v!r}")
    return ds


class FramedSampler(FieldSampler):
    """A snapshot on the CRS axes sampled at positions in the grid coordinates of *frame* (a
    :class:`~breachflow.site.frame.GridFrame`, or None: no rotation): the field at the map positions
    ``frame.to_map(x, y)``, its velocity in grid components (``frame.vector_to_grid``); bed, depth and
    surface are scalars. Rotation-invariant methods (bilinear / barycentric weights of the map positions,
    the neighbourhood disc) make this the regional field seen from the rotated grid. Only :meth:`sample`
    rotates: ``grid_arrays`` / ``mesh_arrays`` stay the snapshot's, on the CRS axes."""

    def __init__(self, snapshot: xr.Dataset, method: str = "bilinear", frame=None, **kw):
        self.frame = frame if frame is not None and frame.rotated else None
        super().__init__(snapshot, method, **kw)

    def sample(self, px, py, radius=None) -> FieldSample:
        if self.frame is None:
            return super().sample(px, py, radius)
        X, Y = self.frame.to_map(px, py)
        s = super().sample(X, Y, radius)
        u, v = self.frame.vector_to_grid(s.u, s.v)
        return FieldSample(s.bed, s.depth, s.surface, u, v, s.inside)

    __call__ = sample


def fill_obstacles(grid: xr.Dataset, layers: int = 3) -> xr.Dataset:
    """A grid snapshot whose obstacle cells (no-flow, e.g. an intact levee at crest elevation) take the
    mean bed, depth and velocity of their open neighbours, *layers* cells deep, so that interpolation
    next to them sees the open flow, not the obstacle (the obstacle mask itself is kept)."""
    if "obstacle" not in grid or grid["obstacle"].dims != ("y", "x") or not grid["obstacle"].values.any():
        return grid
    ob = grid["obstacle"].values.astype(bool)
    fields = {k: np.where(ob, np.nan, grid[k].values.astype(float)) for k in ("bed_elevation", "depth", "u", "v")}
    todo = ob.copy()
    for _ in range(layers):
        known = ~np.isnan(fields["bed_elevation"])
        pad = np.pad(known, 1)
        cnt = pad[:-2, 1:-1].astype(int) + pad[2:, 1:-1] + pad[1:-1, :-2] + pad[1:-1, 2:]
        new = todo & (cnt > 0)
        if not new.any():
            break
        for k, a in fields.items():
            p = np.pad(np.nan_to_num(a), 1)
            tot = p[:-2, 1:-1] + p[2:, 1:-1] + p[1:-1, :-2] + p[1:-1, 2:]
            a[new] = (tot / np.maximum(cnt, 1))[new]
        todo &= ~new
    out = grid.copy()
    for k, a in fields.items():
        keep = np.isnan(a)
        out[k] = grid[k].copy(data=np.where(keep, grid[k].values, a))
    return out


def _regional_obstacle(regional: xr.Dataset, X, Y) -> np.ndarray:
    """The regional grid's obstacle mask at points (nearest cell); none for meshes."""
    if "obstacle" not in regional or regional["obstacle"].dims != ("y", "x"):
        return np.zeros(X.shape, bool)
    xs, ys = regional.x.values, regional.y.values
    i = np.clip(np.round((X - xs[0]) / (xs[1] - xs[0])).astype(int), 0, xs.size - 1)
    j = np.clip(np.round((Y - ys[0]) / (ys[1] - ys[0])).astype(int), 0, ys.size - 1)
    return regional["obstacle"].values.astype(bool)[j, i]


def levee_side(X, Y, levee_y: float, polder_sign: float = 1.0) -> np.ndarray:
    """True at the points ``(X, Y)`` (grid coordinates, the levee along x at *levee_y*) on the flood side:
    ``(Y - levee_y) * polder_sign < 0``, *polder_sign* the direction of the flow through the breach
    (:func:`~breachflow.swe.section.flow_sign`: +1 when the polder lies at larger y)."""
    return (np.asarray(Y, float) - float(levee_y)) * float(polder_sign) < 0.0


def nested_domain(regional: xr.Dataset, box, resolution: float, manning=0.025, *, name: str = "nested",
                  leaving: str = "free", frame=None, terrain=None, flood_side=None):
    """The local :class:`~breachflow.swe.domain.Domain` in *box* ``(x0, x1, y0, y1)`` at *resolution* and its initial state
    ``(h, hu, hv)`` from *regional*; boundary conditions from the regional field (module docstring). With
    *frame* (:class:`~breachflow.site.frame.GridFrame`) the box and the domain are in its grid coordinates
    and the velocities grid components; *regional* stays on the CRS axes.

    *terrain*: the finest source of the terrain, ``terrain(X, Y) -> (bed, obstacle)`` at the local cell centres
    (box coordinates): the analytic geometry of a preset or scene (:func:`breachflow.swe.domain.breach_terrain`)
    or a site's terrain file (:meth:`breachflow.site.domain.Site.terrain_at`). The local bed and no-flow cells are
    then its own, not the regional bed interpolated (which smears a breach wall over the regional cells next to
    it); the initial depth is the regional water surface over the local bed. None: the regional bed.

    *flood_side*: ``flood_side(X, Y) -> bool`` at the local cell centres, True on the flood side of the levee
    (e.g. :func:`levee_side` bound with ``functools.partial``); there water leaving subcritically keeps the
    regional level (module docstring). None: *leaving* everywhere."""
    x0, x1, y0, y1 = map(float, box)
    regional = with_no_flow(regional)  # a raster without a no-flow mask (ESRI grids): dry cells it held dry
    dom = uniform_grid(x0, x1, y0, y1, resolution)
    if min(dom.shape) < 4:
        raise InputError(f"nested box {box} at {resolution} m has only {dom.shape[1]} x {dom.shape[0]} cells")
    X, Y = np.meshgrid(dom.x, dom.y)
    smp = FramedSampler(fill_obstacles(regional), "bilinear", frame).sample(X.ravel(), Y.ravel())
    MX, MY = (X, Y) if frame is None else frame.to_map(X, Y)
    inside = smp.inside.reshape(dom.shape) & ~_regional_obstacle(regional, MX, MY)
    if inside.mean() < 0.5:
        raise InputError(f"nested box {box}: only {100 * inside.mean():.0f} % of it lies inside the regional field")
    bed = smp.bed.reshape(dom.shape)
    h = np.where(inside, np.nan_to_num(smp.depth.reshape(dom.shape)), 0.0)
    # cells outside the regional field (a mesh hole: the intact levee) are no-flow for the flow model and
    # solid for the DEM's terrain (the domain bed): at least as high as the water the levee holds, so that
    # masses meet the breach walls there instead of rolling through the levee (before: the highest open bed)
    fill = max(np.nanmax(bed[inside]), np.nanmax((bed + h)[inside])) if inside.any() else 0.0
    # a raster's no-flow cells (ESRI grids, our own snapshots) keep their own bed, the levee's real shape
    raw = FramedSampler(regional, "bilinear", frame).sample(X.ravel(), Y.ravel()).bed.reshape(dom.shape)
    bed = np.where(inside, bed, np.where(np.isfinite(raw), raw, fill))
    if terrain is not None:
        fine_bed, fine_obstacle = terrain(X, Y)
        fine_bed = np.asarray(fine_bed, float).reshape(dom.shape)
        if not np.all(np.isfinite(fine_bed)):
            bad = np.argwhere(~np.isfinite(fine_bed))[0]
            raise InputError(f"nested box {box}: the terrain has no elevation at "
                             f"({X[tuple(bad)]:.2f}, {Y[tuple(bad)]:.2f})")
        inside = smp.inside.reshape(dom.shape) & ~np.asarray(fine_obstacle, bool).reshape(dom.shape)
        surface = np.nan_to_num(smp.surface.reshape(dom.shape), nan=-np.inf)
        wet0 = inside & (np.nan_to_num(smp.depth.reshape(dom.shape)) > DRY_DEPTH)
        h = np.where(wet0, np.maximum(surface - fine_bed, 0.0), 0.0)
        bed = fine_bed
    u = np.where(inside & (h > DRY_DEPTH), np.nan_to_num(smp.u.reshape(dom.shape)), 0.0)
    v = np.where(inside & (h > DRY_DEPTH), np.nan_to_num(smp.v.reshape(dom.shape)), 0.0)
    dom.bed = bed
    dom.manning = np.broadcast_to(np.asarray(manning, float), dom.shape).copy()
    dom.obstacle = ~inside
    dom.initial_surface = np.where(h > DRY_DEPTH, bed + h, np.nan)
    dom.name = name
    crs = regional["crs"].attrs.get("crs_wkt") if "crs" in regional else None
    dom.crs_wkt = crs
    hmax = float(np.max(h)) if h.size else 1.0
    relaxation = 4.0 * max(x1 - x0, y1 - y0) / np.sqrt(GRAVITY * max(hmax, 1e-3))
    if leaving not in ("free", "level"):
        raise InputError(f"nested solver: leaving = {leaving!r}; use 'free' or 'level'")
    hold = np.full(dom.shape, leaving == "level")
    flood = None
    if flood_side is not None:
        flood = np.asarray(flood_side(X, Y), bool).reshape(dom.shape)
        hold |= flood
    dom.boundaries = _edge_conditions(bed, h, u, v, inside, dom, relaxation, hold, flood)
    return dom, (h, h * u, h * v)


def frame_snapshot(snapshot: xr.Dataset, domain: Domain, frame) -> xr.Dataset:
    """*snapshot* (an ingested field on the CRS axes: grid or mesh) on the cells of *domain*, a grid in the
    turned *frame*'s coordinates (:class:`~breachflow.site.frame.GridFrame`): sampled at the cells' map
    positions as :func:`nested_domain` builds its local model (bed, depth, velocity turned into the grid;
    cells outside the field or in its no-flow cells are obstacles), georeferenced (``map_x``, ``u_east``, ...)."""
    from ..field.snapshot import grid_snapshot

    x, y = np.asarray(domain.x, float), np.asarray(domain.y, float)
    dx, dy = domain.dx, domain.dy
    box = (x[0] - 0.5 * dx, x[-1] + 0.5 * dx, y[0] - 0.5 * dy, y[-1] + 0.5 * dy)
    local, (h, hu, hv) = nested_domain(snapshot, box, dx, frame=frame)
    if local.shape != domain.shape or not (np.allclose(local.x, x) and np.allclose(local.y, y)):
        raise InputError(f"snapshot on a turned grid: cells {local.shape} do not match the domain {domain.shape}")
    wet = h > DRY_DEPTH
    u = np.where(wet, hu / np.where(wet, h, 1.0), 0.0)
    v = np.where(wet, hv / np.where(wet, h, 1.0), 0.0)
    crs = snapshot["crs"].attrs.get("crs_wkt") if "crs" in snapshot else getattr(domain, "crs_wkt", None)
    ds = grid_snapshot(x, y, local.bed, h, u, v, obstacle=local.obstacle, crs_wkt=crs,
                       source=f"{snapshot.attrs.get('source', 'ingested snapshot')} on the breach-aligned grid")
    return frame.georeference(ds)


def edge_conditions(bed, h, u, v, inside, dom: Domain, relaxation=None, leaving_level=False) -> dict:
    """Boundary conditions per side of *dom* from a surrounding field on its edge cells (bed, depth, velocity
    ``(ny, nx)`` arrays; *inside* False = wall): where water enters the absorbing level (supercritical: level
    and unit discharge), where it leaves free outflow (or, *leaving_level*, the level when subcritical; a bool,
    or a ``(ny, nx)`` mask of the cells where it holds), dry cells free outflow (module docstring). Also the
    edges of the region re-solve (:mod:`~breachflow.hydro.resolve_region`)."""
    return _edge_conditions(bed, h, u, v, inside, dom, relaxation, leaving_level)


def _edge_conditions(bed, h, u, v, inside, dom: Domain, relaxation=None, leaving_level=False, flood=None) -> dict:
    # flood: (ny, nx) mask of the flood side; a stretch of one kind is split where it crosses the levee, so that
    # each stretch lies on one side (:func:`edge_on_flood_side`)
    edges = {  # side: (cells along it, inward normal velocity, along-side coordinate)
        "west": (np.s_[:, 0], u[:, 0], dom.y), "east": (np.s_[:, -1], -u[:, -1], dom.y),
        "south": (np.s_[0, :], v[0, :], dom.x), "north": (np.s_[-1, :], -v[-1, :], dom.x),
    }
    hold = np.broadcast_to(np.asarray(leaving_level, bool), h.shape)
    out = {}
    for side, (sl, un_in, s) in edges.items():
        hh, ins = h[sl], inside[sl]
        level = bed[sl] + hh
        c = np.sqrt(GRAVITY * np.maximum(hh, 1e-12))
        leaving = np.where(hold[sl], un_in < -c, un_in < 0.0)
        kind = np.where(~ins, "wall", np.where(hh <= 1e-3, "outflow",
                        np.where(leaving, "outflow", np.where(un_in > c, "discharge", "level"))))
        side_of = np.zeros(s.size, bool) if flood is None else flood[sl]
        bcs = []
        start = 0
        for k in range(1, s.size + 1):
            if k < s.size and kind[k] == kind[start] and side_of[k] == side_of[start]:
                continue
            sel = slice(start, k)
            a, b = float(s[start]), float(s[k - 1])
            kd = kind[start]
            if kd == "wall":
                bcs.append(BoundaryCondition.wall(start=a, stop=b))
            elif kd == "outflow":
                bcs.append(BoundaryCondition.outflow(start=a, stop=b))
            elif kd == "level":
                bcs.append(BoundaryCondition.water_level(level[sel].copy(), start=a, stop=b, absorbing=relaxation))
            else:
                bcs.append(BoundaryCondition.inflow((hh * un_in)[sel].copy(), level=level[sel].copy(), start=a, stop=b))
            start = k
        out[side] = bcs
    return out


def edge_on_flood_side(side: str, bc, domain: Domain, flood_side) -> bool:
    """Whether the stretch *bc* of edge *side* (``"west"``, ...) of *domain* lies on the flood side
    (``flood_side(X, Y)``, :func:`levee_side`): judged at its middle cell; the stretches of a nested domain built
    with that *flood_side* lie on one side each (:func:`nested_domain`)."""
    x, y = np.asarray(domain.x, float), np.asarray(domain.y, float)
    along = y if side in ("west", "east") else x
    a = along[0] if bc.start is None else float(bc.start)
    b = along[-1] if bc.stop is None else float(bc.stop)
    mid = 0.5 * (a + b)
    px, py = {"west": (x[0], mid), "east": (x[-1], mid), "south": (mid, y[0]), "north": (mid, y[-1])}[side]
    return bool(np.asarray(flood_side(np.array([px]), np.array([py])), bool)[0])


def breach_box(xc: float, yc: float, length: float, resolution: float, along: float = 3.0, across: float = 3.0):
    """``(box, spacing)``: the default nested box around a breach of *length* B centred at (xc, yc)
    on a levee along x, with cells of ``B / round(B / resolution)`` and the breach ends on cell faces."""
    n = max(1, int(round(length / resolution)))
    dx = length / n
    k = int(round(along * length / dx))
    m = int(round(across * length / dx))
    return (xc - 0.5 * length - k * dx, xc + 0.5 * length + k * dx, yc - m * dx, yc + m * dx), dx


class NestedSolver:
    """``solver = "nested"``: the local model of :func:`nested_domain`, re-solved with the pile.

    ``NestedSolver(snapshots, box, resolution, manning=...)``; ``domain`` is the local domain
    the closure runs on. ``solve(domain, obstacles=None, initial=None)``: a cold solve starts from the
    regional state; every later one from the previous local state (warm start).

    *terrain*: the local grid's terrain from its finest source (:func:`nested_domain`); None: the regional bed.
    *flood_side*: the flood side of the levee at the local cells (:func:`nested_domain`); None: *leaving* on
    every edge.

    *frame*: the :class:`~breachflow.site.frame.GridFrame` of a site whose levee runs in any direction:
    *box*, the domain, the solutions and the DEM's positions are in its grid coordinates, the regional
    field stays on the CRS axes (:class:`FramedSampler`); the solutions carry their map coordinates."""

    responds_to_pile = True
    mode = "nested"

    def __init__(self, snapshots=None, box=None, resolution: float = 4.0, manning=0.025, *, order: int = 2,
                 courant: float = 0.45, tolerance: float = 2e-3, t_max_initial: float = 300.0, t_max: float = 60.0,
                 region=None, threads: int | None = 1, leaving: str = "free", frame=None, terrain=None,
                 flood_side=None):
        if snapshots is None or box is None:
            raise InputError("nested solver: give snapshots= (the ingested regional field) and box=(x0, x1, y0, y1)")
        self.regional = load_regional(snapshots)
        self.frame = frame if frame is not None and frame.rotated else None
        if "mesh2d_node_x" in self.regional:
            bx, by = self.regional["mesh2d_node_x"].values, self.regional["mesh2d_node_y"].values
        else:  # a grid: the corners of its cell-centre box
            bx, by = np.meshgrid(self.regional.x.values[[0, -1]], self.regional.y.values[[0, -1]])
        if self.frame is not None:
            bx, by = self.frame.to_grid(bx, by)
        w = tuple(map(float, box))
        # the box is clipped to the regional field's bounding box (grid coordinates; outside it there is
        # nothing to nest in) by whole cells, so that its lattice (e.g. breach ends on cell faces) is kept
        r = float(resolution)
        #: the local grid's cell size (m), kept for a rebuild on a new regional field
        self.spacing = r
        cut = lambda lo, hi, sign: (np.ceil(max(sign * (hi - lo), 0.0) / r - 1e-9) * r)
        self.box = (w[0] + cut(w[0], float(np.min(bx)), 1), w[1] - cut(float(np.max(bx)), w[1], 1),
                       w[2] + cut(w[2], float(np.min(by)), 1), w[3] - cut(float(np.max(by)), w[3], 1))
        if not (self.box[1] > self.box[0] and self.box[3] > self.box[2]):
            raise InputError(f"nested box {w} does not overlap the regional field "
                             f"(x {np.min(bx):g}..{np.max(bx):g}, y {np.min(by):g}..{np.max(by):g})")
        #: the local grid's terrain source and the edges' leaving rules, kept for a rebuild on a new regional field
        self.terrain, self.leaving, self.flood_side = terrain, leaving, flood_side
        self.domain, self.initial_state = nested_domain(self.regional, self.box, resolution, manning,
                                                        leaving=leaving, frame=self.frame, terrain=terrain,
                                                        flood_side=flood_side)
        from ..swe.solver import SWEOptions

        self.options = SWEOptions(order=order, courant=courant, threads=threads)
        self.tolerance, self.t_max_initial, self.t_max, self.region = tolerance, t_max_initial, t_max, region
        self.source = self.regional.attrs.get("source", "ingested snapshot")
        self.last = None
        #: breach section ``(x0, x1, y)`` whose discharge must settle too (run_to_steady); None: region only
        self.section = None
        #: the steady window of the solves with a section (``run_to_steady(window=...)``; None: off)
        self.window, self.window_change = None, WINDOW_CHANGE

    def fallback_sampler(self, method: str = "bilinear") -> FieldSampler:
        """The regional field as ingested, sampled where a point lies outside the nested box (the DEM's
        :class:`~breachflow.field.sampling.FieldSampler` ``fallback``): at grid positions, velocity in grid
        components when the grid is rotated (:class:`FramedSampler`); built once per method."""
        cache = self.__dict__.setdefault("_fallback", {})
        if method not in cache:
            cache[method] = FramedSampler(self.regional, method, self.frame)
        return cache[method]

    def solve(self, domain=None, obstacles=None, initial=None) -> xr.Dataset:
        from ..swe.solver import SWESimulation

        domain = self.domain if domain is None else domain
        cold = initial is None
        sim = SWESimulation(domain, self.options, obstacles=obstacles, initial=self.initial_state if cold else initial)
        sim.run_to_steady(self.tolerance, self.t_max_initial if cold else self.t_max, region=self.region,
                          section=self.section, window=self.window if self.section is not None else None,
                          window_change=self.window_change)
        self.last = sim
        ds = sim.snapshot(source=f"breachflow nested local model in {self.source}")
        where = "" if self.frame is None else " (breach-aligned grid coordinates)"
        ds.attrs.update(hydro_mode=self.mode, flow_responds_to_pile=1,
                        hydro_note=(f"local shallow-water model on x {self.box[0]:g}..{self.box[1]:g}, "
                                    f"y {self.box[2]:g}..{self.box[3]:g} m{where} re-solved with the pile; outside "
                                    f"it the ingested field ({self.source}) unchanged"))
        return ds if self.frame is None else self.frame.georeference(ds)


def consistency(local: xr.Dataset, regional: xr.Dataset, centre, radius: float, frame=None) -> dict:
    """Differences between a local solution and the regional field within *radius* (m) of *centre*, over
    local cells wet in both: max / mean ``|Δ speed|`` and ``|Δ depth|`` (m/s, m), the peak speeds of both, the
    mean regional speed and depth there, and the cell count. *frame*: the local grid's
    :class:`~breachflow.site.frame.GridFrame` (*centre* in its grid coordinates)."""
    X, Y = np.meshgrid(local.x.values, local.y.values)
    smp = FramedSampler(fill_obstacles(regional), "bilinear", frame).sample(X.ravel(), Y.ravel())
    rs = np.hypot(smp.u, smp.v).reshape(X.shape)
    rh = smp.depth.reshape(X.shape)
    ls = np.hypot(local.u.values, local.v.values)
    lh = local.depth.values
    ob = local["obstacle"].values.astype(bool) if "obstacle" in local else np.zeros(X.shape, bool)
    sel = ((np.hypot(X - centre[0], Y - centre[1]) <= radius) & smp.inside.reshape(X.shape) & ~ob
           & (rh > 0.01) & (lh > 0.01))
    if not sel.any():
        raise InputError("consistency: no cell wet in both fields near the breach")
    ds_, dh = np.abs(ls - rs)[sel], np.abs(lh - rh)[sel]
    return {"cells": int(sel.sum()), "max_speed_diff": float(ds_.max()), "mean_speed_diff": float(ds_.mean()),
            "max_depth_diff": float(dh.max()), "mean_depth_diff": float(dh.mean()),
            "regional_peak_speed": float(rs[sel].max()), "local_peak_speed": float(ls[sel].max()),
            "regional_mean_speed": float(rs[sel].mean()),
            "regional_mean_depth": float(rh[sel].mean())}
