"""The closure cycle ``<g>`` (docs/theory.md, *The closure cycle*, report Figs 4.2, 4.5, §4.4).

Each cycle: release the cycle's masses above the water (placement plan) → run the DEM in the frozen
field of the current snapshot until the assembly is in equilibrium (``E_TOL``: every mass at rest or
removed from the breach area, :mod:`~breachflow.cycle.losses`; ``max_time`` is only a safety cap) → remap the resting
masses into the hydrodynamic model (no-flow cells or raised bed) → re-solve the flow (warm start;
skipped when the remap changed no cell) → optional stability re-run (criterion 5) → end criteria →
write the cycle to the run directory. The DEM side of a cycle (building, continuing and settling the DEM)
is :mod:`~breachflow.cycle.dem_cycle`; which masses are the pile when the DEM stops,
:mod:`~breachflow.cycle.rest`.

Determinism and resume: cycle ``g``'s DEM continues the DEM of cycle ``g − 1`` in the new frozen field
(kept in memory; after a resume restored bit-identically from the restart record of cycle ``g − 1``),
and the placement draws from ``rng([seed, g])``. A resumed run therefore repeats exactly what an
uninterrupted one does.

Per-cycle cost follows what moves, not the size of the pile: resting masses sleep (with the frozen
field, only awake masses are evaluated), the DEM is not rebuilt between cycles, and the remap
recomputes only the cells under masses that moved, stopped or were added (``IncrementalPileTop``).
"""
from __future__ import annotations

import time as _time
from dataclasses import dataclass, field

import numpy as np
import xarray as xr

from ..dem import Material
from ..errors import InputError
from ..dem.integrators import integrators
from ..fluid.drag import DRAG_LAWS
from ..fluid.profile import DEFAULT_PROFILE
from ..fluid.profile import factors as profile_factors
from ..field.sampling import SAMPLING_METHODS, FieldSampler
from ..schemas import validate
from ..swe.porous_laws import POROUS_LAWS
from ..io import RunDirectory, particles_dataset, trajectories_dataset
from ..io.cf import pad_particles
from ..io.cycle_variables import cycle_coordinate, cycle_variables
from .dem_cycle import CycleDem, dem_view  # noqa: F401  (dem_view: re-exported, the nested tests import it here)
from .criteria import CycleContext, EndCriteria, control_speed, gap_section_speeds, section_discharge, seepage_in_section
from .losses import (LOSS_LIMIT, cannot_close, carried_away_faster, cycle_losses, gap_speed, gap_speed_and_depth,
                     izbash_speed, losses_flagged, not_closable_verdict, rolling_speed, verdict_drag_law)
from .placement import PlacementPlan
from .strategies import PileView
from .strategies import band as strategy_band
from .rest import REST_RULES, RestSample, pile_members
from .remap import IncrementalPileTop, porous_pile, remap_cells, remap_top, subpoints


@dataclass
class DemSettings:
    """DEM settings of a closure run (SI). A cycle's DEM ends at equilibrium (``e_tol``), or when every
    awake mass has moved slower than ``rest_speed`` (centre speed and ``|omega| r``) for ``rest_time``
    (checked every ``record_interval``), or at the safety cap ``max_time`` of simulated time; masses
    carried out of the breach area are removed meanwhile (:mod:`~breachflow.cycle.losses`). Which masses
    count as resting (the pile the remap sees) when the cycle ends at ``max_time``: ``rest_rule``
    (``mean_speed``, the default: mean speed over the last ``rest_time`` below ``rest_speed``; ``speed``: speed
    at the cap instant below ``rest_speed``; :mod:`~breachflow.cycle.rest`);
    ``record_interval`` the trajectory sampling interval (s)."""

    material: Material = field(default_factory=lambda: Material(density=2650.0, kn=2.0e7, friction=0.6,
                                                                 rolling_friction=0.3))
    restitution: float = 0.3
    integrator: str = integrators.default
    e_tol: float = 1.0e-5
    max_time: float = 30.0
    rest_speed: float = 0.05
    record_interval: float = 0.1
    sleeping: bool = True
    global_damping: float = 0.0
    drag_law: str = DRAG_LAWS.default
    sampling: str = SAMPLING_METHODS.default
    xi: float = 0.5
    velocity_profile: str = DEFAULT_PROFILE
    roughness: float | None = None
    stability_time: float = 5.0
    rest_time: float = 0.5
    rest_rule: str = REST_RULES.default
    #: the ``[bed]`` settings (:class:`~breachflow.cycle.config.BedSettings`): rough terrain, near-bed forces,
    #: erosion; None: smooth terrain, centre-height flow
    bed: object = None
    #: per closure material of the placement (the index a release carries): the ``friction``,
    #: ``rolling_friction``, ``drag_coefficient``, ``lift_coefficient`` and ``added_mass_coefficient`` its masses
    #: carry (None: the run's drag law / lift term / ``xi``); empty: every mass takes ``material`` and ``drag_law``
    units: tuple = ()

    def __post_init__(self):
        for name in ("e_tol", "max_time", "rest_speed", "record_interval", "stability_time", "rest_time"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise InputError(f"dem.{name} must be > 0, got {v!r}")
        if not 0 < self.restitution <= 1:
            raise InputError(f"dem.restitution must be in (0, 1], got {self.restitution!r}")
        REST_RULES.get(self.rest_rule)  # an unknown name: InputError listing the rules


@dataclass
class ClosureSetup:
    """Everything a closure run needs (SI).

    ``domain`` the hydrodynamic :class:`~breachflow.swe.domain.Domain`; ``solver`` a HydroSolver;
    ``breach_x`` the breach extent along the levee at ``levee_y``; ``flood_level`` flood-side water
    elevation; ``bottom`` the breach bottom elevation (for the cross-section criteria); ``area`` the
    breach area ``(x0, x1, y0, y1)`` outside which masses are removed and counted as lost (None: the
    whole domain); ``loss_limit`` the fraction of a cycle's placement whose loss (whenever its masses leave),
    in a flow faster than the masses withstand, ends the run with a verdict (:mod:`~breachflow.cycle.losses`).
    """

    domain: object
    solver: object
    placement: PlacementPlan
    criteria: EndCriteria
    dem: DemSettings = field(default_factory=DemSettings)
    remap_mode: str = "no_flow"
    #: how the pile enters ``no_flow`` / ``raised_bed``: ``centre`` | ``cell_average`` (:mod:`~breachflow.cycle.remap`)
    pile_sampling: str = "centre"
    #: flow law of a porous pile (a name of ``swe.porous_laws.POROUS_LAWS``)
    porous_law: str = POROUS_LAWS.default
    seed: int = 0
    breach_x: tuple = (0.0, 0.0)
    levee_y: float = 0.0
    flood_level: float = 0.0
    bottom: float = 0.0
    name: str = "closure"
    #: global attributes added to every cycle file (e.g. the site, or that the flow is frozen)
    attrs: dict = field(default_factory=dict)
    #: extra run metadata for the manifest (JSON-serialisable)
    metadata: dict = field(default_factory=dict)
    area: tuple | None = None
    loss_limit: float = LOSS_LIMIT
    #: warnings of the scenario's sanity check (:func:`breachflow.cycle.sanity.check_setup`)
    warnings: list = field(default_factory=list)
    #: grid ↔ map coordinates of a site whose grid runs along its levee (:class:`breachflow.site.frame.GridFrame`):
    #: everything above is in grid coordinates; the cycle files get the map coordinates (None: grid = map)
    frame: object = None
    #: the closure in time (:class:`~breachflow.cycle.timeline.Timeline`, ``[closure] method``): operation
    #: time from the tonnes delivered, flood stage and polder level per cycle (None: ``[placement] rate``)
    timeline: object = None
    #: +1 when the polder is at +y of the grid, -1 when the flood is: every breach discharge the run reports
    #: counts from the flood side into the polder (:func:`~breachflow.swe.section.flow_sign`)
    flow_sign: float = 1.0


@dataclass
class CycleReport:
    cycle: int
    masses: int
    tonnage: float
    operation_time: float
    max_speed: float
    discharge_proxy: float
    breach_discharge: float
    criteria: list
    closed: bool
    governing: str
    dem_steps: int
    dem_particle_steps: int
    dem_converged: bool
    hydro: str  # "solved (warm start)", "skipped (no cell changed)", "solved (cold start)"
    stability: str
    wall_time: float
    left_domain: int
    lost_cycle: int = 0  #: masses carried out of the breach area in this cycle
    lost_cycle_tonnage: float = 0.0  #: their tonnage (t)
    placed_cycle_tonnage: float = 0.0  #: tonnage placed in this cycle (t)
    lost_cycle_placed_tonnage: float = 0.0  #: of lost_cycle_tonnage, the masses placed in this cycle (t)
    #: largest share of a cycle's placement carried away so far among the cycles whose masses left in this one,
    #: and that cycle (0: none; :class:`~breachflow.cycle.losses.CycleLosses`)
    cohort_lost_fraction: float = 0.0
    cohort_cycle: int = 0
    lost_tonnage: float = 0.0  #: tonnage lost over the run so far (t); the number is ``left_domain``
    gap_speed: float = 0.0  #: largest flow speed in the breach area (m/s)
    losses_flagged: bool = False  #: more than ``loss_limit`` of all placed tonnage lost so far
    verdict: str = ""  #: why the run ends without closure (empty while it goes on)
    time_solve: float = 0.0  #: wall time (s) of the re-solve
    time_dem: float = 0.0  #: wall time (s) of the DEM settle
    time_output: float = 0.0  #: wall time (s) of writing the cycle
    cpu_solve: float = 0.0  #: CPU time (s) of this process in the re-solve
    cpu_dem: float = 0.0  #: CPU time (s) of the DEM settle
    #: part of breach_discharge through the porous pile (remap "porous"; 0 otherwise), m³/s
    seepage_discharge: float = 0.0
    #: masses in the domain still moving at the end of the cycle's DEM (not at rest)
    not_at_rest: int = 0
    #: flow speed in the gap section (the breach at the levee line, where breach_discharge is taken):
    #: largest, and depth-weighted mean (:func:`~breachflow.cycle.criteria.gap_section_speeds`), m/s
    gap_max_speed: float = 0.0
    gap_mean_speed: float = 0.0
    #: flood-side and polder water levels of the cycle's solve (m, datum of the bed; polder NaN without a timeline)
    flood_level: float = float("nan")
    polder_level: float = float("nan")
    #: the timeline's state after the cycle (:meth:`~breachflow.cycle.timeline.Timeline.state`; {} without one)
    timeline: dict = field(default_factory=dict)
    #: deepest scour of an erodible bed in this cycle's flow (m) and where (:mod:`~breachflow.cycle.scour`)
    scour_depth: float = 0.0
    scour_x: float = float("nan")
    scour_y: float = float("nan")
    #: the erodible bed's change over this cycle's flow time (:func:`~breachflow.cycle.scour.cycle_bed_change`):
    #: deepest lowering of the terrain (m) and where, largest rise (m), flow time reached of the one asked (s)
    bed_lowering: float = 0.0
    bed_lowering_x: float = float("nan")
    bed_lowering_y: float = float("nan")
    bed_rise: float = 0.0
    bed_change_time: float = 0.0
    bed_change_duration: float = 0.0
    bed_change_steps: int = 0
    #: the rock stage's end judged on this cycle (:class:`~breachflow.cycle.rock_end.RockEnd`; {} when not judged)
    rock_end: dict = field(default_factory=dict)

    def as_dict(self) -> dict:
        d = dict(self.__dict__)
        d["criteria"] = [dict(r.__dict__) for r in self.criteria]
        return d


class ClosureRun:
    """Drive a closure run in a run directory: ``ClosureRun(setup, run_dir, scenario_text).run()``."""

    def __init__(self, setup: ClosureSetup, run_dir, scenario_text: str, *, resume: bool = False,
                 overwrite: bool = False, progress=None, metadata: dict | None = None, start_states=None,
                 take_start: bool = True, weir_coefficient: float | None = None):
        self.setup = setup
        # the coefficient the weir calibrations begin from (the verdict check's finer grid: the run's own); a
        # start calibrated from it is this run's own (its key does not hold the coefficient): not shared
        self.weir_coefficient = None if weir_coefficient is None else float(weir_coefficient)
        if self.weir_coefficient is not None:
            if not (np.isfinite(self.weir_coefficient) and self.weir_coefficient > 0):
                raise InputError(f"weir_coefficient: the coefficient the weir calibrations begin from must be a "
                                 f"positive number (m^0.5/s), got {weir_coefficient!r}")
            start_states = None
        self._weir_taken = None  # the coefficient the start's calibration began from, when it was taken
        # the store of start states (breachflow.cycle.start_state): the run takes its start from it when one of
        # its key is there (unless *take_start* is false), else writes its own there; None: the run solves its
        # start and keeps it to itself
        self.start_states = start_states
        self.take_start = bool(take_start)
        self._start_key = None
        if start_states is not None:
            from .start_state import reusable, start_key

            self._start_key = start_key(scenario_text) if reusable(setup.solver) else None
        dom = setup.domain
        # everything is checked before the run directory is touched: a bad scenario leaves nothing behind
        setup.placement.check_inside((dom.x[0] - 0.5 * dom.dx, dom.x[-1] + 0.5 * dom.dx),
                                     (dom.y[0] - 0.5 * dom.dy, dom.y[-1] + 0.5 * dom.dy))
        self.rundir = RunDirectory(run_dir)
        self.rundir.start(scenario_text, seed=setup.seed, resume=resume, overwrite=overwrite,
                          metadata={"name": setup.name, **setup.metadata, **(metadata or {})})
        self.progress = progress  # callable(CycleReport) or None
        self.reports: list[CycleReport] = []
        self.dem = CycleDem(setup)  # the DEM of the cycles
        self._pile = IncrementalPileTop(setup.domain.x, setup.domain.y, setup.domain.bed,
                                        sub=subpoints(dom.dx, dom.dy, 0.5 * setup.placement.diameter[0]),
                                        cells=setup.pile_sampling == "cell_average")
        self._pile_height = None  # porous remap: the pile heights of the last solve
        self._q_open = float("nan")  # breach discharge of the open breach (the initial solve), m³/s
        self._t_op = 0.0  # operation time of the last cycle (s): the erodible bed's flow time runs from it
        self.seal = None  # the seal stage (cycle/sealing.py) of a closed run whose criterion has a seal

    def _set_terrain(self, bed) -> None:
        """The erodible bed's new terrain: the domain the SWE re-solves on, the pile's base, the DEM's height
        field (rebuilt from the saved state at the next cycle)."""
        from dataclasses import replace as _replace

        from ..swe.domain import _copy_spacing

        s, old = self.setup, self.setup.domain
        s.domain = _replace(old, bed=np.array(bed, float))
        _copy_spacing(old, s.domain)
        self._pile = IncrementalPileTop(s.domain.x, s.domain.y, s.domain.bed, sub=self._pile.sub,
                                        cells=self._pile.cells)
        self.dem.live = None

    # ------------------------------------------------------------------ restart record
    def _initial_record(self) -> dict:
        return {"placed_cycle": np.zeros(0, np.int32), "resting": np.zeros(0, bool),
                "material_index": np.zeros(0, np.int8)}

    # ------------------------------------------------------------------ main loop
    def run(self) -> list[CycleReport]:
        """Run the cycles (from the last committed one), then release the run directory's lock."""
        try:
            return self._run()
        finally:
            self.rundir.close()

    def _run(self) -> list[CycleReport]:
        s = self.setup
        done = self.rundir.completed_cycles()
        if done:
            g0 = done[-1]
            rec = self.rundir.load_restart(g0)
            if "pile_height" in rec:
                self._pile_height = np.asarray(rec["pile_height"], float)
            if "terrain_bed" in rec:  # an erodible bed: the terrain as the last cycle left it
                self._set_terrain(rec["terrain_bed"])
            self._t_op = float(self.rundir.manifest()["cycles"][-1]["summary"].get("operation_time", 0.0))
            snapshot = self._grid_only(self.rundir.open_cycle(g0))
            self._q_open = float(self.rundir.manifest().get("metadata", {}).get("initial", {}).get(
                "breach_discharge", float("nan")))
            closed = bool(self.rundir.manifest()["cycles"][-1]["summary"].get("closed"))
            if s.timeline is not None:  # the clock and the polder where the last complete cycle left them
                s.timeline.restore(self.rundir.manifest()["cycles"][-1]["summary"]["timeline"])
            if closed or self.rundir.manifest().get("finished"):
                if closed and "seal" not in self.rundir.manifest().get("metadata", {}):
                    self._resume_seal(rec, snapshot)  # a run closed before the seal stage: add it
                return self.reports
        else:
            g0 = 0
            rec = self._initial_record()
            t0, c0 = _time.perf_counter(), _time.process_time()
            stored = self._stored_start()
            if stored is not None:  # the same start, solved by another run (breachflow.cycle.start_state)
                snapshot, window_cpu = self._take_start(stored), (None, None)
            else:
                snapshot, window_cpu = self._solve_start()
            self.initial_solve_time = _time.perf_counter() - t0
            initial_solve_cpu = _time.process_time() - c0
            from .criteria import DischargeProxy, MaxSpeed

            ctx0 = CycleContext(cycle=0, snapshot=snapshot, breach_x=s.breach_x, levee_y=s.levee_y,
                                flow_sign=s.flow_sign)
            self._q_open = section_discharge(snapshot, s.breach_x, s.levee_y, s.flow_sign)
            gmax, gmean = gap_section_speeds(snapshot, s.breach_x, s.levee_y)
            yc, vc = control_speed(snapshot, s.breach_x, s.levee_y)
            if s.timeline is not None:
                s.timeline.record(self._q_open, "start")
                self.rundir.update_metadata(timeline_start={**s.timeline.state(),
                                                            "prestart": list(s.timeline.history),
                                                            "weir_calibration": list(s.timeline.calibration),
                                                            "window_calibration": dict(s.timeline.window_calibration)})
            if stored is None and self._start_key is not None:
                from .start_state import save

                save(self.start_states, self._start_key, snapshot, s.timeline)
            self.rundir.update_metadata(initial={
                "max_speed": MaxSpeed("0 m/s", region="domain").value(ctx0),
                "discharge_proxy": DischargeProxy("0 m^3/s").value(ctx0),
                "breach_discharge": self._q_open,
                "gap_speed": gap_speed(snapshot, s.area if s.area is not None else (-np.inf, np.inf, -np.inf, np.inf)),
                "gap_max_speed": gmax, "gap_mean_speed": gmean, "control_speed": vc if np.isfinite(vc) else None,
                "control_y": yc if np.isfinite(yc) else None,
                "solve_wall_time": self.initial_solve_time, "solve_cpu_time": initial_solve_cpu,
                "window_calibration_cpu_time": window_cpu[0], "window_solve_is_start_solve": window_cpu[1],
                "start_state": self._start_record(stored), "weir_calibration_from": self._weir_taken},
                warnings=list(s.warnings))
        from .leakage import undesignable_seal

        blocked = undesignable_seal(s.criteria)  # the criterion's seal cannot be made for this rock: no cycle runs
        for g in range(g0 + 1, (g0 if blocked else s.criteria.max_cycles) + 1):
            rep, rec, snapshot = self._cycle(g, rec, snapshot)
            self.reports.append(rep)
            if self.progress:
                self.progress(rep)
            if rep.closed or rep.verdict:
                break
        last = self.reports[-1] if self.reports else None
        verdict = last.verdict if last else (blocked or "")
        if last and not last.closed and not verdict and self.rundir.last_cycle() >= s.criteria.max_cycles:
            verdict = f"not closed after max_cycles = {s.criteria.max_cycles} cycles"
        closed = bool(last and last.closed)
        if closed:  # the seal in the flow model (cycle/sealing.py) when the criterion has one
            from .sealing import record_seal, seal_stage

            self.seal = seal_stage(s, rec, snapshot)
            if self.seal is not None:
                closed, verdict = record_seal(self.rundir, self.seal, s)
        self.rundir.finish({"cycles": self.rundir.last_cycle(), "closed": closed,
                            "governing": last.governing if last else "", "verdict": verdict,
                            "lost_masses": last.left_domain if last else 0,
                            "lost_tonnage": last.lost_tonnage if last else 0.0,
                            "losses_flagged": bool(last and last.losses_flagged),
                            **({"seal": self.seal.verdict} if self.seal is not None else {})})
        return self.reports

    def _solve_start(self):
        """The steady open breach the first cycle starts from, solved: under the closure in time the polder
        filled to the start, the window's and the start's weir calibrations. Returns ``(snapshot, window_cpu)``
        (the window calibration's CPU s and whether its solve was the start's, or Nones without a timeline)."""
        s = self.setup
        first, window_cpu = None, (None, None)
        if s.timeline is not None:  # the breach grows and the polder fills until the start of the closure
            self._weir_taken = s.timeline.calibrate_from(self.weir_coefficient)
            s.timeline.begin()
            self._t_op = float(s.timeline.time)  # an erodible bed's first flow time: the first delivery
            # the closure window's weir, calibrated once on the open breach at its full size (the same for
            # every start; first solved, so that no solve of this run's start comes before it)
            cw = _time.process_time()
            first = s.timeline.calibrate_window(lambda: s.solver.solve(s.domain),
                                                lambda snap: section_discharge(snap, s.breach_x, s.levee_y,
                                                                               s.flow_sign))
            # its CPU (with the start's own first solve when the start is the reference: handed on)
            window_cpu = (_time.process_time() - cw, first is not None)
        snapshot = first if first is not None else s.solver.solve(s.domain)
        if s.timeline is not None:  # the pre-start weir calibrated on this open breach at the start
            snapshot = s.timeline.calibrate(snapshot, lambda prev: s.solver.solve(s.domain, initial=prev),
                                            lambda snap: section_discharge(snap, s.breach_x, s.levee_y,
                                                                           s.flow_sign))
        return snapshot, window_cpu

    def _take_start(self, stored):
        """The start another run solved, *stored* = ``(snapshot, timeline state)``: the timeline set to its
        state; returns the snapshot."""
        from .start_state import restore_timeline

        snapshot, saved = stored
        tl = self.setup.timeline
        restore_timeline(tl, saved)
        if tl is not None:
            tl.history.pop()  # its "start" record: written again by the caller, as for a start solved here
            self._t_op = float(tl.time)
        return snapshot

    def _stored_start(self):
        """``(snapshot, timeline state)`` of this run's start from the store of start states, or None."""
        if self._start_key is None or not self.take_start:
            return None
        from .start_state import load

        return load(self.start_states, self._start_key)

    def _start_record(self, stored) -> dict | None:
        """The manifest's record of the start state: its key and file, and whether this run solved it."""
        if self._start_key is None:
            return None
        from .start_state import path_of

        return {"key": self._start_key, "file": str(path_of(self.start_states, self._start_key)),
                "solved": stored is None}

    def _resume_seal(self, rec, snapshot) -> None:
        """The seal stage of a run whose rock dam closed without it (the run directory's final record is
        updated: closed only when the seal meets the criterion)."""
        from .sealing import record_seal, seal_stage

        self.seal = seal_stage(self.setup, rec, snapshot)
        if self.seal is None:
            return
        closed, verdict = record_seal(self.rundir, self.seal, self.setup)
        final = dict(self.rundir.manifest().get("final", {}))
        final.update(closed=closed, verdict=verdict, seal=self.seal.verdict)
        self.rundir.finish(final)

    @staticmethod
    def _grid_only(ds: xr.Dataset) -> xr.Dataset:
        keep = [v for v in ds.data_vars if "particle" not in ds[v].dims and v != "scour_depth"]
        return ds[keep]

    def _cycle(self, g, rec, snapshot):
        s = self.setup
        wall0 = _time.perf_counter()
        d = s.dem
        # 1. the DEM continues the previous cycle's (in memory, or restored from its saved state after a
        #    resume): resting masses asleep, their wake reference the old field, so a changed flow wakes
        #    the ones it really affects
        sim = self.dem.for_cycle(g, snapshot, rec)
        # 2. release this cycle's masses
        sampler = FieldSampler(snapshot, method="bilinear")

        def surface_at(x, y):
            smp = sampler.sample(np.asarray(x, float), np.asarray(y, float))
            return np.where(smp.inside, np.maximum(smp.surface, smp.bed), np.nan)

        sill = self._pile_view(sim, rec) if s.placement.uses_pile else None
        st = sim.state
        in_breach = np.flatnonzero(st.active[:st.n])
        rel = s.placement.release(g, s.seed, surface_at, pile=sill, placed=(st.pos[in_breach], st.radius[in_breach]))
        new_ids = self.dem.add(sim, rel.pos, rel.radius, rel.density, material=rel.material)
        placed_cycle = np.concatenate([rec["placed_cycle"], np.full(len(new_ids), g, np.int32)])
        material_index = _material_index(rec, placed_cycle.size, new_ids, rel.material)
        if s.timeline is not None:  # the operation time after delivering every mass placed so far
            s.timeline.advance(float(sim.state.mass[:sim.state.n].sum()))
        # 3. settle in the frozen field, recording the moving masses
        steps0, ps0 = sim.steps, sim.particle_steps
        moving = np.flatnonzero(sim.state.awake & sim.state.active)
        active0 = sim.state.active.copy()
        t_dem, c_dem = _time.perf_counter(), _time.process_time()
        converged, t_rec, frames, vframes, history = self.dem.settle(sim, d.max_time, record_ids=moving)
        t_dem, c_dem = _time.perf_counter() - t_dem, _time.process_time() - c_dem
        st = sim.state
        lost_now = np.flatnonzero(active0 & ~st.active)
        # the pile: the masses at rest by the rest rule ([dem] rest_rule, cycle/rest.py); they sleep
        w, pos_ref = history.reference()
        sample = RestSample(st.active, st.awake, np.linalg.norm(st.vel, axis=1), st.pos, pos_ref, w, converged)
        resting = pile_members(d.rest_rule, sample, d.rest_speed)
        sim.sleep(np.flatnonzero(resting & st.awake))
        # 4. remap and re-solve
        dom = s.domain
        top = self._pile.update(st.pos, st.radius, resting)
        # emergent (blocked) where the pile reaches the flood-side level, the highest level a steady flow fed
        # from there can back up to: not the previous surface, which the pile itself raised (and which is
        # the old top in the cells it blocked), so a blocked cell stayed blocked only by chance (issue 16)
        flood = np.full(dom.shape, float(s.flood_level if s.timeline is None else s.timeline.flood_level))
        if s.pile_sampling == "cell_average":
            obstacle, bed = remap_cells(self._pile.lift, self._pile.level, dom.bed, flood, s.remap_mode)
        else:
            obstacle, bed = remap_top(top, dom.bed, flood, s.remap_mode)
        pile = None
        if s.remap_mode == "porous":
            pile = porous_pile(dom.x, dom.y, dom.bed, st.pos, st.radius, resting, law=s.porous_law)
            solve_domain = dom.with_porous(pile)
        else:
            solve_domain = dom if s.remap_mode == "no_flow" else dom.with_raised_bed(bed > dom.bed, bed)
        new_obstacle = dom.obstacle | obstacle
        before = snapshot["obstacle"].values.astype(bool) if "obstacle" in snapshot else np.zeros(dom.shape, bool)
        changed = int(np.count_nonzero(new_obstacle != before))
        if pile is not None:
            last = self._pile_height if self._pile_height is not None else np.zeros(dom.shape)
            changed += int(np.count_nonzero(np.abs(pile.height - last) > 1e-9))
            self._pile_height = pile.height
        if s.remap_mode == "raised_bed":
            changed += int(np.count_nonzero(np.abs(solve_domain.bed - snapshot["bed_elevation"].values) > 1e-9))
        t_solve, c_solve = _time.perf_counter(), _time.process_time()
        if changed == 0:
            new_snapshot = snapshot
            hydro = "skipped (remap changed no cell)"
        elif getattr(s.solver, "responds_to_pile", True) is False:
            new_snapshot = s.solver.solve(solve_domain, obstacles=obstacle, initial=snapshot)
            hydro = f"frozen flow, does not respond to the pile ({changed} cells changed)"
        else:
            new_snapshot = s.solver.solve(solve_domain, obstacles=obstacle, initial=snapshot)
            hydro = f"solved (warm start, {changed} cells changed)"
            if new_snapshot.attrs.get("hydro_region"):  # [hydro] resolve = "region": where it was re-solved
                hydro = hydro[:-1] + f"; region {new_snapshot.attrs['hydro_region']})"
        t_solve, c_solve = _time.perf_counter() - t_solve, _time.process_time() - c_solve
        new_rec = {"dem." + k: v for k, v in sim.save_state().items()}
        new_rec.update(placed_cycle=placed_cycle, resting=resting.copy(), material_index=material_index)
        if pile is not None:
            new_rec["pile_height"] = pile.height.copy()
        # 5. stability re-run (criterion 5) only when asked for
        stab = None
        stability = "not requested"
        if s.criteria.needs("stability") and resting.any():
            stab = self._stability(new_rec, resting, new_snapshot)
            stability = f"re-run {d.stability_time:g} s: max displacement {stab:.3g} m"
        ctx = CycleContext(cycle=g, snapshot=new_snapshot, previous=snapshot, pos=st.pos, radius=st.radius,
                           resting=resting, breach_x=s.breach_x, levee_y=s.levee_y,
                           flood_level=s.flood_level if s.timeline is None else s.timeline.flood_level,
                           bottom=s.bottom, stability_displacement=stab,
                           seepage_discharge=self._seepage(new_snapshot, pile), area=s.area,
                           open_breach_discharge=self._q_open, flow_sign=s.flow_sign)
        closed, results, governing = s.criteria.evaluate(ctx)
        rock_end = None
        if closed and pile is not None:  # a sealed rock dam: the rock stage ends on a steady solve (cycle/rock_end.py)
            new_snapshot, ctx, closed, results, governing, rock_end = self._rock_end(
                new_snapshot, ctx, pile, solve_domain, obstacle, closed, results, governing)
        from .criteria import DischargeProxy, MaxSpeed

        max_speed = MaxSpeed("0 m/s", region="domain").value(ctx)
        proxy = DischargeProxy("0 m^3/s").value(ctx)
        q_breach = section_discharge(new_snapshot, s.breach_x, s.levee_y, s.flow_sign)
        if s.timeline is not None:
            s.timeline.record(q_breach)
        gap_max, gap_mean = gap_section_speeds(new_snapshot, s.breach_x, s.levee_y)
        from .scour import cycle_scour

        scour_map, scour_max, scour_x, scour_y = cycle_scour(s, new_snapshot)
        # 6. write the cycle
        masses = int(st.n)
        tonnage = float(st.mass[st.active].sum()) / 1000.0
        losses = cycle_losses(st.mass, placed_cycle, active0, st.active, g)
        lost_total_t = float(st.mass[:st.n][~st.active[:st.n]].sum()) / 1000.0
        area = s.area if s.area is not None else (-np.inf, np.inf, -np.inf, np.inf)
        gspeed, verdict = gap_speed(new_snapshot, area), self._verdict(g, closed, losses, lost_now, new_ids, rel, snapshot, area)
        rep = CycleReport(cycle=g, masses=masses, tonnage=tonnage, operation_time=rel.time, max_speed=max_speed,
                          discharge_proxy=proxy, breach_discharge=q_breach, criteria=results, closed=closed, governing=governing,
                          dem_steps=sim.steps - steps0, dem_particle_steps=sim.particle_steps - ps0,
                          dem_converged=converged, hydro=hydro, stability=stability,
                          wall_time=_time.perf_counter() - wall0, left_domain=int((~st.active[:st.n]).sum()),
                          lost_cycle=int(lost_now.size), lost_cycle_tonnage=losses.lost, placed_cycle_tonnage=losses.placed,
                          lost_cycle_placed_tonnage=losses.lost_placed, cohort_lost_fraction=losses.cohort_fraction,
                          cohort_cycle=losses.cohort, lost_tonnage=lost_total_t, gap_speed=gspeed, verdict=verdict,
                          losses_flagged=losses_flagged(lost_total_t, tonnage + lost_total_t, s.loss_limit),
                          time_solve=t_solve, time_dem=t_dem, cpu_solve=c_solve, cpu_dem=c_dem,
                          seepage_discharge=ctx.seepage_discharge,
                          not_at_rest=int((st.active[:st.n] & ~resting[:st.n]).sum()),
                          gap_max_speed=gap_max, gap_mean_speed=gap_mean, scour_depth=scour_max, scour_x=scour_x,
                          scour_y=scour_y)
        if rock_end is not None:
            rep.rock_end = rock_end.as_dict()
        if s.timeline is not None:
            rep.operation_time, rep.timeline = s.timeline.time, s.timeline.state()
            rep.flood_level, rep.polder_level = s.timeline.flood_level, s.timeline.polder_level
        else:
            rep.flood_level = float(s.flood_level)
        # an erodible bed changes under this cycle's flow until the next cycle's masses (the pile's cells hold)
        from .scour import cycle_bed_change

        new_terrain, bed_info = cycle_bed_change(s, new_snapshot, rep.operation_time - self._t_op,
                                                 fixed=np.isfinite(top) & (top > dom.bed + 1e-6))
        self._t_op = rep.operation_time
        if new_terrain is not None:
            new_rec["terrain_bed"] = new_terrain
            for k, v in bed_info.items():
                setattr(rep, k, v)
        t_out = _time.perf_counter()
        field_ds = self._field_dataset(new_snapshot, st, placed_cycle, resting, rep, material_index)
        if scour_map is not None:
            field_ds["scour_depth"] = scour_map.expand_dims("cycle").assign_coords(cycle=field_ds["cycle"])
        field_ds = validate(field_ds, "closure_cycle")
        traj = None
        if moving.size:
            tt = np.broadcast_to(t_rec, (moving.size, t_rec.size))  # seconds since the cycle's release
            traj = validate(trajectories_dataset(moving, tt, frames, vframes, cycle=g, cycle_start=rel.time),
                            "closure_trajectories")
            if s.frame is not None and s.frame.rotated:  # positions in grid coordinates: say how they map
                traj.attrs.update(s.frame.attrs())
        rep.time_output = _time.perf_counter() - t_out  # the summary records the time up to the write itself
        self.rundir.write_cycle(g, field_ds, traj, new_rec, _summary(rep))
        self.dem.live = (g, sim)
        if new_terrain is not None:
            self._set_terrain(new_terrain)
        return rep, new_rec, new_snapshot

    def _verdict(self, g, closed, losses, lost_now, new_ids, rel, snapshot, area) -> str:
        """The "not closable" statement (:func:`~breachflow.cycle.losses.not_closable_verdict`) when the rule
        :func:`~breachflow.cycle.losses.cannot_close` holds for cycle *g* ("" otherwise), in the field *snapshot*
        the masses felt: gap speed against Izbash's, speed at a mass's centre against the rolling speed."""
        s, d = self.setup, self.setup.dem
        if closed or not carried_away_faster(losses, s.loss_limit):
            return ""
        diam = float(np.median(2.0 * rel.radius))
        rho = float(np.median(rel.density))
        speed, depth = gap_speed_and_depth(snapshot, area)
        factor = float(profile_factors(d.velocity_profile, 0.5 * diam, depth, self.dem.fluid_roughness()))
        roll = rolling_speed(diam, rho, d.material.rolling_friction, verdict_drag_law(d, s.placement))
        if not cannot_close(losses, s.loss_limit, speed=speed, izbash=float(izbash_speed(diam, rho)),
                            felt_speed=factor * speed, roll_speed=roll):
            return ""
        return not_closable_verdict(g, lost_now.size, len(new_ids), losses.lost, losses.placed, 2.0 * rel.radius,
                                    rel.density, speed, lost_placed=int(np.isin(lost_now, new_ids).sum()),
                                    roll_speed=roll, bed_factor=factor, cohort=losses)

    def _pile_view(self, sim, rec) -> PileView:
        """The sill along the placement's gap line before this cycle's release, for the strategies that
        read it, from the masses (:meth:`~breachflow.cycle.strategies.PileView.from_masses`): terrain and the
        masses that rest after the previous cycle (its restart record, so an uninterrupted and a resumed run
        see the same), within the dam section (:func:`~breachflow.cycle.strategies.band`) of the line; the
        level to reach is the flood level."""
        s, p, st = self.setup, self.setup.placement, sim.state
        resting = np.zeros(len(st.radius), bool)
        prev = np.asarray(rec["resting"], bool)
        m = min(prev.size, resting.size)
        resting[:m] = prev[:m]
        dom = s.domain
        return PileView.from_masses(dom.x, dom.y, dom.bed, st.pos, st.radius, resting & st.active[:resting.size],
                                    p.start, p.stop, band=strategy_band(p),
                                    level=float(s.flood_level if s.timeline is None else s.timeline.flood_level))

    def _stability(self, rec, resting, snapshot) -> float:
        """Criterion 5: the assembly, every mass awake, re-run in the new flow for ``stability_time``;
        returns the largest displacement of a resting mass (inf if one left the domain)."""
        d = self.setup.dem
        sim = self.dem.make(snapshot, self.dem.state_of(rec))
        sim.wake_all()
        start = sim.state.pos.copy()
        sim.step(int(np.ceil(d.stability_time / sim.dt)))
        disp = np.linalg.norm(sim.state.pos - start, axis=1)
        disp = np.where(sim.state.active, disp, np.inf)[resting]
        return float(disp.max()) if disp.size else 0.0

    def _rock_end(self, snapshot, ctx, pile, solve_domain, obstacle, closed, results, governing):
        """The rock stage's end (:mod:`~breachflow.cycle.rock_end`) for a run sealed after the rock: continue a
        re-solve that stopped before its steady state (up to the criterion's ``steady_cap``), judge the criteria
        again on it, and let the dam hold only when the solve is steady and the crest stands above the flood
        level all along the gap, read from the resting masses (or, with ``rock_end = "overflow"``, the overflow
        criterion is met)."""
        from dataclasses import replace as _replace

        from . import rock_end as R
        from .sealing import seal_criterion

        s = self.setup
        crit = seal_criterion(s)
        if crit is None:
            return snapshot, ctx, closed, results, governing, None
        flood = float(ctx.flood_level)
        xs, crests = R.gap_crests(ctx.pos, ctx.radius, ctx.resting, s.domain.x, s.domain.y, s.domain.bed,
                                  s.breach_x, s.levee_y, flood)
        unit = float(np.mean(s.placement.diameter))
        emergent = R.judge(crit.rock_end, True, 0.0, 1, xs, crests, flood, False, unit).emergent
        if crit.rock_end == "emergent" and not R.CONTINUE_SUBMERGED and not emergent:
            # a crest below the flood cannot hold whatever the flow: the re-solve is not continued
            steady, sim_t, n = R.is_steady(snapshot), R.simulated_time(snapshot), 1
        else:
            snapshot, steady, sim_t, n = R.continue_to_steady(
                lambda prev: s.solver.solve(solve_domain, obstacles=obstacle, initial=prev), snapshot, crit.steady_cap)
        if n > 1:  # the criteria judged again on the continued solve
            ctx = _replace(ctx, snapshot=snapshot, seepage_discharge=self._seepage(snapshot, pile))
            closed, results, governing = s.criteria.evaluate(ctx)
        over = next((r.satisfied for r in results if r.name == "overflow_discharge"), False)
        end = R.judge(crit.rock_end, steady, sim_t, n, xs, crests, flood, over, unit)
        if not end.held:
            closed, governing = False, ""
        return snapshot, ctx, closed, results, governing, end

    def _seepage(self, snapshot, pile) -> float:
        """Discharge through the porous pile across the breach section (m³/s), from the steady split of
        each cell's unit discharge (:func:`~breachflow.swe.porous.seepage_field`)."""
        if pile is None or not pile.any:
            return 0.0
        s = self.setup
        from ..swe.porous import seepage_field

        h = np.asarray(snapshot["depth"].values, float)
        u = np.asarray(snapshot["u"].values, float)
        v = np.asarray(snapshot["v"].values, float)
        speed = np.hypot(u, v)
        q_seep = seepage_field(h, speed, pile, s.domain.manning)
        x = np.asarray(snapshot["x"].values, float)
        j = int(np.argmin(np.abs(np.asarray(snapshot["y"].values, float) - s.levee_y)))
        sel = (x >= s.breach_x[0]) & (x <= s.breach_x[1])
        frac_y = np.where(speed[j] > 0, v[j] / np.where(speed[j] > 0, speed[j], 1.0), 0.0)
        dx = abs(x[1] - x[0]) if x.size > 1 else 1.0
        return seepage_in_section(snapshot, s.breach_x, s.levee_y, float(np.sum((q_seep[j] * frac_y)[sel]) * dx),
                                  s.flow_sign)

    def _field_dataset(self, snapshot, st, placed_cycle, resting, rep, material_index=None) -> xr.Dataset:
        grid = self._grid_only(snapshot)
        units = self.setup.placement.unit_parameters()
        part = particles_dataset(st, placed_cycle=placed_cycle, resting=resting,
                                 grid_mapping="crs" if "crs" in grid else None, material=material_index,
                                 material_names=[u["name"] for u in units] if units else ["sphere"],
                                 run_drag_coefficient=getattr(self.setup.dem.drag_law, "value", None),
                                 run_added_mass_coefficient=self.setup.dem.xi)
        # the run's capacity (masses inserted otherwise, as the cycle benchmark's pile, can exceed it)
        part = pad_particles(part, max(self.setup.criteria.max_cycles * self.setup.placement.batch, st.n))
        ds = xr.merge([grid, part], combine_attrs="override")
        ds.attrs.update(grid.attrs)
        ds.attrs.update(self.setup.attrs)
        # per-cycle figures are variables along ``cycle`` (output.cycle_variables), not global attributes:
        # xr.open_mfdataset would keep the first file's attributes for every cycle
        bx = self.setup.breach_x
        ds.attrs.update(title=f"breachflow closure run {self.setup.name!r}",
                        placement_strategy=self.setup.placement.positions,
                        breach_section=f"{bx[0]:.3f} {bx[1]:.3f} {self.setup.levee_y:.3f}")
        from .timeline import cycle_variables as timeline_variables

        # flood and polder levels and the operation time of the closure in time (breach_discharge is in the
        # per-cycle table of output.cycle_variables)
        ds = ds.assign({k: v for k, v in timeline_variables(rep, self.setup.timeline).items() if k != "breach_discharge"})
        if self.setup.frame is not None:
            ds = self.setup.frame.georeference(ds)
        return with_cycle_dimension(ds, rep.cycle).assign(cycle_variables(rep))


def with_cycle_dimension(ds: xr.Dataset, g: int) -> xr.Dataset:
    """Give a cycle's Dataset the length-1 ``cycle`` dimension coordinate ``xr.open_mfdataset("RUN/cycle_*.nc")``
    stacks the cycles along: on every per-cycle variable (not on ``crs`` nor on the grid coordinates).
    The particles are padded to the run's capacity (same ``particle`` index in every cycle) and the
    steady-state history, whose length varies, is written to the group ``convergence_history``."""
    ds = ds.copy()
    for name in list(ds.data_vars):
        if name != "crs" and "cycle" not in ds[name].dims:
            ds[name] = ds[name].expand_dims("cycle")
    # units "count" (UDUNITS, dimensionless), not "1": GDAL passes coordinate attributes as text tags and
    # rioxarray's open_rasterio turns "1" into the int 1 and fails testing it for "since" (rioxarray <= 0.23)
    return ds.assign_coords(cycle=cycle_coordinate([g]))


def _summary(rep: CycleReport) -> dict:
    d = rep.as_dict()
    d["criteria"] = {r["name"]: {"value": r["value"], "threshold": r["threshold"], "units": r["units"],
                                 "satisfied": r["satisfied"]} for r in d["criteria"]}
    return d


def _material_index(rec, n, new_ids, material) -> np.ndarray:
    """Each DEM slot's index into the placement's materials (``particle_material`` of the cycle files): the
    record's, then *material* (None: spheres, 0) at the slots *new_ids* of this cycle's masses. A record written
    before the index was kept gives -1 (unknown) to its masses."""
    old = np.asarray(rec.get("material_index", np.full(len(rec["placed_cycle"]), -1)), np.int8)
    out = np.concatenate([old, np.full(n - old.size, -1, np.int8)])
    out[np.asarray(new_ids, int)] = 0 if material is None else np.asarray(material, np.int8)
    return out
