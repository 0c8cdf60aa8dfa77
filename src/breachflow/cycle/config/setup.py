"""From a parsed scenario to a :class:`~breachflow.cycle.driver.ClosureSetup`
(:func:`~breachflow.cycle.config.closure_setup`): the scene or terrain site, the flow solver (with the
warm-start, stage-hydrograph and nested wrappers), the DEM settings, placement, criteria and breach area."""
from __future__ import annotations

from dataclasses import replace
from functools import partial

import numpy as np

from ...errors import InputError
from ...scenario.geometry import BreachGeometry
from ...swe.section import flow_sign
from ..criteria import EndCriteria
from ..leakage import DEFAULT_ALLOWED_RISE
from ..losses import breach_area
from ..placement import PlacementPlan
from .closure import ClosureSection
from .dem import DemSection, FluidSection
from .hydro import HydroSection
from .site import SiteSection, _crs_wkt


def closure_setup(scenario, *, overrides: dict | None = None):
    """Build the :class:`~.driver.ClosureSetup` of a parsed scenario (missing sections take defaults)."""
    from ...dem import Material
    from ...hydro.solvers import solvers
    from ...swe.domain import breach_domain
    from ..driver import ClosureSetup, DemSettings

    site = scenario.get("site") or SiteSection()
    hydro = scenario.get("hydro") or HydroSection()
    attrs = {}
    metadata = {}
    if hasattr(site, "build"):  # a terrain site (breachflow.site)
        # the embedded, nested and frozen-snapshot solvers run on a grid along the levee (any direction;
        # a frozen field is served on it); a plug-in's field stays on the CRS axes
        built = site.build(hydro.resolution, align=hydro.solver in ("swe", "nested", "snapshot", "snapshot_frozen"))
        dom = built.domain
        (xc, yc), half = built.centre, 0.5 * built.breach.length
        flood_level, bottom = built.flood_level, built.breach.bottom
        metadata["site"] = _jsonable(built.report)
        attrs.update(site_terrain=str(built.terrain.path.name), site_levee=str(built.levee.source).split("/")[-1],
                     site_breach_centre=f"{xc:.3f} {yc:.3f}", site_flood_side=built.report["flood_side"])
    else:
        levee = scenario["levee"].geometry if "levee" in scenario else None
        breach = None
        if "breach" in scenario and scenario["breach"].length is not None:
            b = scenario["breach"]
            base = site.scene().breach
            breach = BreachGeometry(length=float(b.length), depth=float(b.depth) if b.depth is not None else base.depth,
                                    wall_slope=float(b.wall_slope) if b.wall_slope is not None else base.wall_slope,
                                    scour_depth=float(b.scour_depth) if b.scour_depth is not None else base.scour_depth)
        scene = site.scene(levee, breach)
        built = None
        dom = breach_domain(scene, hydro.resolution)
        dom.crs_wkt = _crs_wkt(site.crs)
        (xc, yc), half = (0.0, 0.0), 0.5 * scene.breach.length
        flood_level = scene.flood_water_elevation
        bottom = scene.ground_elevation + scene.levee.height - scene.breach.depth - scene.breach.scour_depth
    nested = coarse = None  # coarse: (domain, solver) of a refine's coarse model
    if hydro.solver == "nested" or hydro.refine is not None:
        from ...hydro.nested import NestedSolver, breach_box, levee_side

        fine = hydro.resolution if hydro.refine is None else hydro.refine
        regional = hydro.snapshots
        if hydro.refine is not None:  # the coarse open-breach steady state is the regional field
            if built is not None and built.stage is not None:
                raise InputError("[hydro] refine: a stage hydrograph of the site is not supported with a nested grid")
            Xc, Yc = np.meshgrid(dom.x, dom.y)
            reg_c = (np.abs(Xc - xc) <= half + hydro.monitor_radius) & (np.abs(Yc - yc) <= hydro.monitor_radius + half)
            coarse = (dom, _WarmStartSWE(hydro, reg_c, section=(xc - half, xc + half, yc)))
            regional = [coarse[1].cold.solve(dom)]
            metadata.update(refine_coarse_resolution=hydro.resolution, refine_resolution=hydro.refine)
        # an ingested field is on the CRS axes: the local grid of a rotated site samples it in its frame
        # (a refine's coarse steady state is already on the site's grid)
        frame = built.frame if built is not None and hydro.refine is None and built.frame.rotated else None
        box, spacing = breach_box(xc, yc, 2.0 * half, fine)
        if hydro.nested_box is not None:
            if frame is not None:
                raise InputError(f"[hydro] nested_box = {list(hydro.nested_box)} is a box on the CRS axes, but the grid of this "
                                 f"site runs along the levee ({frame.angle_deg:.1f}° from the CRS x axis); leave it out "
                                 f"(the default box is the breach ± (B/2 + 3 B) along the levee and ± 3 B across)")
            box, spacing = hydro.nested_box, fine
        terrain = None
        if hydro.refine is not None:  # the nested grid's terrain from its finest source, not the coarse bed
            if built is not None:
                terrain = built.terrain_at
            else:
                from ...swe.domain import breach_terrain

                terrain = breach_terrain(scene)
        # water leaving the box on the flood side keeps the regional level: the flood channel does not drain
        # out of the box (hydro/nested.py)
        flood_side = partial(levee_side, levee_y=yc, polder_sign=flow_sign(built.flood_sign) if built is not None else 1.0)
        nested = NestedSolver(regional, box, spacing, manning=float(np.mean(dom.manning)),
                              order=hydro.order, courant=hydro.courant, tolerance=hydro.tolerance,
                              t_max_initial=hydro.t_max_initial, t_max=hydro.t_max, frame=frame, terrain=terrain,
                              flood_side=flood_side)
        nested.window, nested.window_change = hydro.steady_window, hydro.steady_window_change
        if nested.domain.crs_wkt is None:  # regional files without a CRS (e.g. ADH without its .prj): the site's
            nested.domain.crs_wkt = dom.crs_wkt
        elif built is not None and hydro.refine is None:
            _check_regional_crs(nested.domain.crs_wkt, dom.crs_wkt, nested.source, built.terrain.path)
        if hydro.refine is not None:
            nested.source = f"breachflow swe steady state at {hydro.resolution:g} m cells (coarse domain)"
            nested.section = (xc - half, xc + half, yc)
        dom = nested.domain
        metadata.update(hydro_mode="nested", nested_box=list(nested.box), nested_regional=nested.source,
                        nested_cells=list(dom.shape))
    X, Y = np.meshgrid(dom.x, dom.y)
    region = (np.abs(X - xc) <= half + hydro.monitor_radius) & (np.abs(Y - yc) <= hydro.monitor_radius + half)
    if nested is not None:
        nested.region = region
        solver = nested
    elif hydro.solver == "swe":
        solver = _WarmStartSWE(hydro, region, section=(xc - half, xc + half, yc))
        if built is not None and built.stage is not None:
            solver = _StageSolver(solver, built)
    else:
        import warnings

        with warnings.catch_warnings():  # the deprecation was reported where the scenario was parsed
            warnings.simplefilter("ignore", DeprecationWarning)
            turned = built.frame if built is not None and built.frame.rotated else None
            solver = (solvers.create(hydro.solver, snapshots=hydro.snapshots, domain=dom, frame=turned)
                      if hydro.solver in ("snapshot", "snapshot_frozen") else solvers.create(hydro.solver))
    if getattr(solver, "responds_to_pile", True) is False:
        from ...errors import BreachflowWarning
        from ...hydro.solvers import FROZEN_NOTE

        attrs.update(hydro_mode=getattr(solver, "mode", hydro.solver), flow_responds_to_pile=np.int32(0),
                     hydro_note=FROZEN_NOTE)
        metadata.update(hydro_mode=getattr(solver, "mode", hydro.solver), flow_responds_to_pile=False)
        import warnings

        warnings.warn(f"[hydro] solver = {hydro.solver!r}: {FROZEN_NOTE}", BreachflowWarning, stacklevel=2)
    dem_vals = dict((scenario.get("dem") or DemSection()).values)
    mat_keys = {k: dem_vals.pop(k) for k in ("kn", "ks", "friction", "rolling_friction", "adhesion") if k in dem_vals}
    dem_kw = {}
    if "global_damping" in dem_vals:
        dem_kw["global_damping"] = dem_vals.pop("global_damping")
    mat = {**DemSection.MATERIAL_DEFAULTS, **mat_keys}
    material = Material(density=2650.0, kn=mat["kn"], ks=mat.get("ks"), friction=mat["friction"],
                        adhesion=mat["adhesion"], rolling_friction=mat["rolling_friction"])
    fluid = scenario.get("fluid") or FluidSection()
    dem = DemSettings(material=material, drag_law=fluid.drag_law, sampling=fluid.sampling, xi=fluid.xi,
                      velocity_profile=fluid.velocity_profile, roughness=fluid.roughness,
                      bed=scenario["bed"].settings if "bed" in scenario else None,
                      **dem_vals, **dem_kw)
    closure = scenario.get("closure") or ClosureSection()
    placement = scenario["placement"].plan if "placement" in scenario else PlacementPlan(
        diameter=(1.4, 1.6), batch=4, positions="line", start=(xc - half + 0.5, yc), stop=(xc + half - 0.5, yc))
    mat_params = placement.dem_parameters()
    if mat_params is not None:
        # the closure material sets friction, rolling resistance and the shape's drag; [dem] keys given
        # explicitly still win (cycle/placement.py, breachflow.materials); each mass carries its own
        # material's values (dem.units), the run-wide ones are the mix's (tonnage-weighted, shared drag)
        own = dem.material
        upd = {k: mat_params[k] for k in ("friction", "rolling_friction")
               if k not in mat_keys and mat_params[k] is not None}
        dem = replace(dem, material=replace(dem.material, **upd))
        if mat_params["drag_coefficient"] is not None:
            from ...fluid.drag import DRAG_LAWS

            dem = replace(dem, drag_law=DRAG_LAWS.create("constant", value=mat_params["drag_coefficient"]))
        units = tuple({**u, **{k: mat_keys[k] if k in mat_keys else getattr(own, k) if u[k] is None else u[k]
                               for k in ("friction", "rolling_friction")}}
                      for u in placement.unit_parameters())
        dem = replace(dem, units=units)
        metadata.update(material=placement.mix.name, material_drag_coefficient=mat_params["drag_coefficient"],
                        material_friction=dem.material.friction,
                        material_rolling_friction=dem.material.rolling_friction)
        if len(units) > 1:
            metadata["material_units"] = [dict(u) for u in units]
    if placement.positions not in ("zone", "list") and placement.start == placement.stop == (0.0, 0.0):
        # no line given (line, vertical, horizontal): across the breach along the levee centreline, one
        # radius in from the walls (the breach heads)
        r = 0.5 * placement.diameter[1]
        placement.start, placement.stop = (xc - half + r, yc), (xc + half - r, yc)
    elif built is not None and built.frame.rotated:
        placement = _placement_to_grid(placement, built.frame)
    if built is not None and built.frame.rotated and closure.area is not None:
        raise InputError(f"[closure] area = {list(closure.area)} is a box on the CRS axes, but the grid of this site "
                         f"runs along the levee ({built.frame.angle_deg:.1f}° from the CRS x axis); leave it out "
                         f"(the breach area is then the whole domain)")
    # without [criteria]: a porous pile is closed when the overflow has stopped and the polder takes what still
    # leaks through it (cycle/leakage.py; without a polder: seepage below 30 % of the open breach's discharge);
    # an impervious one when the flow in the breach is slow
    criteria = scenario["criteria"].criteria if "criteria" in scenario else EndCriteria.from_config(
        {"mode": "all", "max_cycles": 20, "overflow_discharge": "0.5 m^3/s", "polder_leakage": f"{DEFAULT_ALLOWED_RISE} m/day"}
        if closure.remap == "porous" else {"mode": "any", "max_cycles": 20, "max_speed": "0.5 m/s"})
    for item in criteria.items:
        if hasattr(item, "bind_scenario"):
            item.bind_scenario(scenario)
    # discharges count from the flood side into the polder, whichever way the levee line was digitised
    polder_sign = flow_sign(built.flood_sign) if built is not None else 1.0
    timeline = None
    if closure.timeline.method is not None:
        # an ingested model takes its boundaries from its own result: the method's clock with the flood held frozen
        ingested = not isinstance(solver, (_WarmStartSWE, _StageSolver)) and coarse is None
        frozen = ingested or closure.timeline.flood == "frozen"
        from .timeline import build_timeline, shifted_boundaries
        from ..timeline import TimelineSolver

        if built is not None:
            ground, wall = bottom, float(built.breach.wall_slope)
        else:
            ground, wall = scene.ground_elevation, scene.breach.wall_slope
        from .timeline import polder_terrain

        terrain = None
        if "polder" in scenario and scenario["polder"].storage == "terrain":
            terrain = polder_terrain(scenario["polder"], dom, (xc, yc), polder_sign)
        timeline = build_timeline(scenario, closure.timeline, site_level=flood_level, ground=ground, bottom=bottom,
                                  length=2.0 * half, wall_slope=wall, built=built,
                                  levee=None if built is not None else scene.levee, placement=placement,
                                  terrain=terrain, frozen=frozen)
        if frozen and isinstance(solver, _StageSolver):
            raise InputError("[closure] flood = \"frozen\" holds the flood level, but [site] flood_stage moves it: "
                             "leave one of them out")
        if frozen:
            from ..frozen_timeline import frozen_flood

            timeline = frozen_flood(timeline, flood_level, hydro.solver if ingested else None)
            attrs["closure_timeline_note"] = timeline.note
        elif coarse is not None:  # a nested finer grid: its edges follow the coarse model at the timeline's levels
            from .nested_timeline import NestedTimelineSolver

            base = coarse[0].boundaries
            solver = NestedTimelineSolver(
                solver, TimelineSolver(coarse[1], timeline, lambda level, b=base, z=flood_level: shifted_boundaries(b, level - z)),
                coarse[0], regional[0], manning=float(np.mean(coarse[0].manning)),
                site_level=flood_level)
        else:
            base = dom.boundaries
            inner = solver.inner if isinstance(solver, _StageSolver) else solver
            solver = TimelineSolver(inner, timeline, lambda level, b=base, z=flood_level: shifted_boundaries(b, level - z))
        metadata["timeline"] = {"method": timeline.method.name, "start_s": timeline.start,
                                "description": timeline.describe()}
    if isinstance(solver, _StageSolver):
        solver.plan = placement
    setup = ClosureSetup(domain=dom, solver=solver, placement=placement, criteria=criteria, dem=dem,
                         remap_mode=closure.remap, pile_sampling=closure.pile_sampling, porous_law=closure.porous_law, seed=closure.seed,
                         breach_x=(xc - half, xc + half), levee_y=yc,
                         flood_level=flood_level, bottom=bottom, name=scenario.name, attrs=attrs, metadata=metadata,
                         area=closure.area or (breach_area(scene, placement.diameter[1]) if built is None else None),
                         loss_limit=closure.loss_limit, frame=built.frame if built is not None else None,
                         timeline=timeline, flow_sign=polder_sign)
    for k, v in (overrides or {}).items():
        setattr(setup, k, v)
    from ..sanity import check_setup

    setup.warnings = check_setup(setup)
    return setup


def _placement_to_grid(placement, frame):
    """The release positions of *placement* (given in the site CRS) in the grid coordinates of a rotated
    site (:class:`~breachflow.site.frame.GridFrame`); a new plan, the scenario's is left as it is."""
    if placement.positions == "zone":
        raise InputError(f"[placement] zone = {list(placement.zone)} is a box on the CRS axes, but the grid of this "
                         f"site runs along the levee ({frame.angle_deg:.1f}° from the CRS x axis); give positions = "
                         f"'line' (start, stop) or 'list' (points) in the site CRS instead")
    to_grid = lambda p: tuple(float(v) for v in frame.to_grid(p[0], p[1]))
    return replace(placement, start=to_grid(placement.start), stop=to_grid(placement.stop),
                   points=[to_grid(p) for p in placement.points])


class _WarmStartSWE:
    """The ``swe`` solver with a longer time limit for the first (cold) solve than for warm starts; the
    steady state is judged on depth and discharge in *region* and on the breach discharge (*section*
    ``(x0, x1, y)``, the levee centreline across the breach)."""

    def __init__(self, hydro: HydroSection, region, section=None):
        from ...hydro.solvers import solvers

        kw = dict(order=hydro.order, courant=hydro.courant, tolerance=hydro.tolerance, region=region,
                  section=section, threads=hydro.threads, average=hydro.steady_average,
                  window=hydro.steady_window, window_change=hydro.steady_window_change)
        self.cold = solvers.create("swe", t_max=hydro.t_max_initial, **kw)
        self.warm = solvers.create("swe", t_max=hydro.t_max, **kw)
        if getattr(hydro, "cold_start", "cold") == "coarse":
            from ...hydro.coarse_start import CoarseStartSWE

            self.cold = CoarseStartSWE(self.cold)
        self.region = None
        if hydro.resolve == "region":
            from ...hydro.resolve_region import RegionResolver

            self.region = RegionResolver(self.warm, margin=hydro.resolve_margin, edge_level=hydro.resolve_edge_level,
                                         far=hydro.resolve_far,
                                         far_factor=hydro.resolve_far_factor if hydro.resolve_far == "coarse" else None)

    @property
    def memoryless(self) -> bool:
        """No state carried from one solve to the next (a run may take its start from another run's,
        :mod:`breachflow.cycle.start_state`): true unless a region re-solve or a coarse start is set."""
        return self.region is None and type(self.cold) is type(self.warm)

    def solve(self, domain, obstacles=None, initial=None):
        self._used = self.cold if initial is None else (self.region or self.warm)
        return self._used.solve(domain, obstacles=obstacles, initial=initial)

    @property
    def last(self):
        """The simulation of the last solve (:class:`~breachflow.swe.solver.SWESimulation`), None before one."""
        used = self.__dict__.get("_used")
        return None if used is None else used.last


class _StageSolver:
    """A solver whose flood-side level follows a stage hydrograph: solve ``k`` (0 the initial one) uses the
    stage at the operation time of cycle ``k`` (quasi-steady: each cycle's flow is the steady state at the
    level of the moment its masses are placed)."""

    def __init__(self, inner, site, plan=None):
        self.inner, self.site, self.plan, self.calls = inner, site, plan, 0

    def solve(self, domain, obstacles=None, initial=None):
        t = 0.0 if self.plan is None else self.plan.operation_time(self.calls * self.plan.batch)
        self.calls += 1
        level = self.site.level_at(t)
        from ...swe.domain import _copy_spacing

        d = replace(domain, boundaries=self.site.with_level(level).boundaries)
        _copy_spacing(domain, d)
        return self.inner.solve(d, obstacles=obstacles, initial=initial)

    @property
    def last(self):
        """The simulation of the last solve, as the inner solver keeps it."""
        return getattr(self.inner, "last", None)


def _jsonable(obj):
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, (np.floating, np.integer)):
        return obj.item()
    return obj


def _check_regional_crs(regional_wkt: str, site_wkt: str, regional_name: str, terrain_path) -> None:
    """A regional model in another CRS than the site's terrain would put the breach in the wrong place:
    refuse it. Both CRSs must be metric for the comparison (an ingested model in feet was converted to
    metres at ingest, but its CRS still names feet: not compared)."""
    from pyproj import CRS

    try:
        reg, site = CRS.from_user_input(regional_wkt), CRS.from_user_input(site_wkt)
    except Exception:  # noqa: BLE001 - an unreadable CRS is reported where it is read, not here
        return
    metric = all(c.axis_info and all(a.unit_name in ("metre", "meter") for a in c.axis_info) for c in (reg, site))
    if metric and not reg.equals(site, ignore_axis_order=True):
        raise InputError(f"[hydro] snapshots: the regional model ({regional_name}) is in {reg.name!r} but the "
                         f"site's terrain ({terrain_path}) is in {site.name!r}; re-project one of them (e.g. "
                         f"`gdalwarp -t_srs` for the terrain) so both use the same CRS")
