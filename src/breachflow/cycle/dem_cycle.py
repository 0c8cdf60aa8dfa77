"""The DEM side of a closure cycle (docs/theory.md, *The closure cycle*): the DEM of a cycle (terrain, the frozen fluid field
of the current snapshot, the masses' material), continued from the previous cycle or restored from its
restart record, and the settle loop that steps it until the assembly is at rest or the safety cap.

:class:`CycleDem` is the part of a :class:`~breachflow.cycle.driver.ClosureRun` (``ClosureRun.dem``) that holds
it, built from the run's :class:`~breachflow.cycle.driver.ClosureSetup`.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import xarray as xr

from ..dem import DemSimulation, HeightField
from ..dem.state import UNSET
from ..fluid.forces import FluidForces
from ..fluid.profile import roughness_from_manning
from ..field.sampling import FieldSampler
from ..field.snapshot import DRY_DEPTH
from .rest import RestHistory


def dem_view(snapshot: xr.Dataset) -> xr.Dataset:
    """The field the DEM sees: obstacle cells (placed masses) filled with the still water of their wet
    neighbours, so that a mass inside a blocked cell keeps its buoyancy (the hydrodynamic solver
    empties blocked cells)."""
    if "obstacle" not in snapshot or not snapshot["obstacle"].values.any():
        return snapshot
    ob = snapshot["obstacle"].values.astype(bool)
    bed = snapshot["bed_elevation"].values
    ws = np.where(snapshot["depth"].values > DRY_DEPTH, snapshot["water_surface"].values, np.nan)
    todo = ob & np.isnan(ws)
    for _ in range(64):  # spread neighbour water levels into blocked areas (a few cells thick)
        if not todo.any():
            break
        pad = np.pad(ws, 1, constant_values=np.nan)
        neigh = np.stack([pad[:-2, 1:-1], pad[2:, 1:-1], pad[1:-1, :-2], pad[1:-1, 2:]])
        cnt = np.isfinite(neigh).sum(axis=0)
        fill = np.where(cnt > 0, np.nansum(neigh, axis=0) / np.maximum(cnt, 1), np.nan)
        new = todo & np.isfinite(fill)
        if not new.any():
            break
        ws = np.where(new, fill, ws)
        todo &= ~new
    depth = np.where(ob & np.isfinite(ws), np.maximum(ws - bed, 0.0), snapshot["depth"].values)
    out = snapshot.copy()
    out["depth"] = out["depth"].copy(data=depth)
    out["water_surface"] = out["water_surface"].copy(data=bed + depth)
    out["wet"] = out["wet"].copy(data=(depth > DRY_DEPTH).astype("i1"))
    for k in ("u", "v"):
        out[k] = out[k].copy(data=np.where(ob, 0.0, out[k].values))
    return out


class CycleDem:
    """The DEM of the closure cycles of one run (``ClosureRun.dem``): builds it from a
    :class:`~breachflow.cycle.driver.ClosureSetup`, continues it from cycle to cycle (``live``) or
    restores it from a restart record, inserts the masses and settles it."""

    def __init__(self, setup):
        self.setup = setup
        self.live = None  # (cycle, DemSimulation) of the last cycle, continued by the next one

    @staticmethod
    def state_of(rec) -> dict | None:
        """The DEM's saved state in the restart record *rec* (its ``dem.`` entries), or None."""
        dem = {k[4:]: v for k, v in rec.items() if k.startswith("dem.")}
        return dem or None

    def fluid(self, snapshot) -> FluidForces:
        """The frozen fluid field of *snapshot* as the DEM's force model."""
        d = self.setup.dem
        field = dem_view(snapshot)
        fallback = getattr(self.setup.solver, "fallback_sampler", None)  # nested: the ingested field outside the nested box
        if fallback is not None:
            field = FieldSampler(field, d.sampling, fallback=fallback(d.sampling))
        bed = d.bed
        return FluidForces(field, drag_law=d.drag_law, sampling=d.sampling, xi=d.xi, outside="air",
                           velocity_profile=d.velocity_profile, roughness=self.fluid_roughness(),
                           manning=float(np.median(self.setup.domain.manning)),
                           near_bed=None if bed is None else bed.near_bed)

    def for_cycle(self, g, snapshot, rec):
        """The DEM of cycle *g*: the previous cycle's simulation continued in the field of *snapshot*, or
        (first cycle, or after a resume) restored from the restart record *rec*; both are the same state."""
        live, self.live = self.live, None  # a cycle that fails half-way leaves no half-advanced DEM behind
        if live is not None and live[0] == g - 1:
            sim = live[1]
            sim.set_models([self.fluid(snapshot)])
            return sim
        return self.make(snapshot, self.state_of(rec))

    def make(self, snapshot, dem_state=None):
        """The DEM of a cycle: terrain height field + the frozen fluid field of *snapshot*; continued
        bit-identically from *dem_state* (``save_state`` of the previous cycle) when given."""
        s = self.setup
        d = s.dem
        dom = s.domain
        terrain = HeightField(dom.x, dom.y, dom.bed, self.terrain_material(),
                              roughness=None if d.bed is None else d.bed.roughness)
        x0, x1, y0, y1 = s.area if s.area is not None else (dom.x[0] - 0.5 * dom.dx, dom.x[-1] + 0.5 * dom.dx,
                                                               dom.y[0] - 0.5 * dom.dy, dom.y[-1] + 0.5 * dom.dy)
        # masses leaving this box (the breach area) are retired by the DEM and counted as lost
        box = (x0, x1, y0, y1, float(dom.bed.min()) - 50.0, float(dom.bed.max()) + 200.0)
        fluid = self.fluid(snapshot)
        kw = dict(boundaries=[terrain], models=[fluid], integrator=d.integrator, domain=box, sleeping=d.sleeping,
                  static_models=True)
        if dem_state is not None:
            return DemSimulation.from_state(dem_state, **kw)
        return DemSimulation(**kw)

    def material(self, density, mass_ref):
        """The configured material at *density*, its normal dashpot giving the configured restitution
        for a wall impact of *mass_ref* (docs/theory.md, *DEM contact*: e = exp(-zeta pi / sqrt(1 - zeta^2)))."""
        d = self.setup.dem
        m = replace(d.material, density=float(density), c_gn=d.global_damping)
        return m.with_restitution(d.restitution, mass_ref)

    def terrain_material(self):
        """Terrain contact properties: pair values are the minimum of the partners' (docs/theory.md, *DEM contact*), so the
        terrain's dashpot is sized for the heaviest possible mass and the particle's own value governs."""
        p = self.setup.placement
        heaviest = p.density[1] * 4.0 / 3.0 * np.pi * (0.5 * p.diameter[1]) ** 3
        return self.material(p.density[1], heaviest)

    def add(self, sim, pos, radius, density, vel=None, omega=None, material=None):
        """Insert masses, one call per distinct density and material (no per-particle Python work for big piles).

        *material* (n,): each mass's index into the run's closure materials (``DemSettings.units``, the
        placement's mix); its masses carry that material's friction, rolling resistance, drag, lift and
        apparent-mass coefficients (docs: *Materials and the seal*). None (spheres): the run's ``[dem]`` material and drag law."""
        idx = np.zeros(len(radius), int)
        units = self.setup.dem.units
        which = np.zeros(len(radius), int) if material is None or not units else np.asarray(material, int)
        for rho in np.unique(density):
            for m in np.unique(which[density == rho]):
                sel = np.flatnonzero((density == rho) & (which == m))
                mass_ref = rho * 4.0 / 3.0 * np.pi * float(np.median(radius[sel])) ** 3
                mat = self.material(rho, mass_ref)
                own = {}
                if material is not None and units:
                    u = units[int(m)]
                    mat = replace(mat, friction=u["friction"], rolling_friction=u["rolling_friction"])
                    own = {k: (UNSET if u.get(k) is None else u[k])
                           for k in ("drag_coefficient", "lift_coefficient", "added_mass_coefficient")}
                idx[sel] = sim.add_particles(pos[sel], radius[sel], mat, vel=None if vel is None else vel[sel],
                                             omega=None if omega is None else omega[sel], **own)
        return idx

    def settle(self, sim, max_time, record_ids=None):
        """Step to equilibrium; returns (converged, times, positions and velocities of *record_ids* at those
        times, the :class:`~breachflow.cycle.rest.RestHistory` of every mass's positions over the last
        ``rest_time``)."""
        d = self.setup.dem
        chunk = max(1, int(round(d.record_interval / sim.dt)))
        consecutive = min(chunk, max(10, int(np.ceil(0.05 / sim.dt))))
        times = [0.0]
        frames = [sim.state.pos[record_ids].copy()] if record_ids is not None else []
        vframes = [sim.state.vel[record_ids].copy()] if record_ids is not None else []
        t_start = sim.t
        history = RestHistory(d.rest_time, sim.t, sim.state.pos)
        converged = False
        slow_since = None  # simulated time since when every awake mass is slower than rest_speed
        while sim.t - t_start < max_time:
            res = sim.run_to_equilibrium(d.e_tol, max_steps=chunk, consecutive=consecutive)
            history.add(sim.t, sim.state.pos)
            if record_ids is not None:
                times.append(sim.t - t_start)
                frames.append(sim.state.pos[record_ids].copy())
                vframes.append(sim.state.vel[record_ids].copy())
            if res.converged:
                converged = True
                break
            st = sim.state
            a = np.flatnonzero(st.awake & st.active)
            fast = a.size and max(float(np.linalg.norm(st.vel[a], axis=1).max()),
                                  float((np.linalg.norm(st.omega[a], axis=1) * st.radius[a]).max())) >= d.rest_speed
            if fast:
                slow_since = None
            elif slow_since is None:
                slow_since = sim.t
            elif sim.t - slow_since >= d.rest_time - 1e-9:
                converged = True  # every mass at rest (or removed) for rest_time
                break
        if record_ids is None:
            return converged, np.asarray(times), None, None, history
        return converged, np.asarray(times), np.stack(frames, axis=1), np.stack(vframes, axis=1), history

    def fluid_roughness(self) -> float:
        """The log law's roughness height of the DEM's fluid forces (as :meth:`fluid` sets it)."""
        d = self.setup.dem
        if d.roughness is not None:
            return float(d.roughness)
        ks = float(roughness_from_manning(np.median(self.setup.domain.manning)))
        if d.bed is not None and d.bed.roughness.ks is not None:
            # a rough bed: its grain roughness k_s = 2 d_bed (fluid/bed.py) is a lower bound of the flow's
            # roughness, which the SWE's Manning n (with bed forms) may exceed
            return max(float(d.bed.roughness.ks), ks)
        return ks
