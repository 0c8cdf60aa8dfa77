"""Driver of the embedded shallow-water solver (docs/theory.md, *Shallow-water equations*): state, time marching, steady state, output.

>>> from breachflow.swe.domain import uniform_grid, BoundaryCondition
>>> dom = uniform_grid(0, 10, 0, 1, 0.5, initial_surface=1.0)
>>> sim = SWESimulation(dom)
>>> sim.advance_to(1.0).t
1.0
"""
from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass, field

import numba
import numpy as np
import xarray as xr

from ..errors import InputError, PhysicsError
from ..field import derived as _derived
from .section import channel_discharge
from ..field.snapshot import DRY_DEPTH, grid_snapshot
from .steady_mean import BatchMeans
from .domain import Domain, pack_boundaries
from . import kernels as K

#: the section discharge's largest relative range over the steady window (``run_to_steady(window=...)``):
#: 1 %, half the verdict check's 2 % between grids (docs/verdict-check.md)
WINDOW_CHANGE = 0.01

GRAVITY = 9.81


@dataclass(frozen=True)
class SWEOptions:
    """Numerical settings.

    ``order`` 1 or 2 (MUSCL + SSP-RK2); ``courant`` the CFL number ``dt (|u|+c)/dx + dt (|v|+c)/dy``
    (0 < C <= 1; depth positivity is guaranteed for C <= 0.5); ``limiter`` minmod / mc / vanleer;
    ``riemann`` hll / hllc; ``h_dry`` depth (m) below which a cell's velocity is zero; ``threads`` the
    number of numba threads (None: numba's default, all cores); ``skip_quiet`` skips the flux work of
    quiet cells — water at rest with one level, dry land — whose update is below ``quiet_tolerance``
    times their depth (0: only cells whose update is exactly zero, results identical to computing every
    cell; ``breachflow.swe.step.activity``).
    """

    order: int = 2
    courant: float = 0.45
    limiter: str = "minmod"
    riemann: str = "hllc"
    gravity: float = GRAVITY
    h_dry: float = 1e-8
    dt_min: float = 1e-9
    threads: int | None = 1
    skip_quiet: bool = True
    quiet_tolerance: float = 1e-14

    def __post_init__(self):
        if self.order not in (1, 2):
            raise InputError(f"order must be 1 or 2, got {self.order!r}")
        if not (0.0 < self.courant <= 1.0):
            raise InputError(f"courant must be in (0, 1], got {self.courant!r}")
        if self.limiter not in K.LIMITERS:
            raise InputError(f"limiter {self.limiter!r} unknown; use one of {sorted(K.LIMITERS)}")
        if self.riemann not in K.RIEMANN:
            raise InputError(f"riemann {self.riemann!r} unknown; use one of {sorted(K.RIEMANN)}")
        if not (0.0 <= self.quiet_tolerance <= 1e-6):
            raise InputError(f"quiet_tolerance must be in [0, 1e-6], got {self.quiet_tolerance!r}")
        if not (self.gravity > 0 and self.h_dry >= 0):
            raise InputError("gravity must be > 0 and h_dry >= 0")


@dataclass
class ConvergenceHistory:
    """Steady-state monitor: per check, simulated time (s), relative rates of change of depth and of
    discharge (1/s, L1 over the open cells), the discharge through the monitored section (m³/s, NaN
    without one) and its relative rate of change (1/s), steps and wall time (s)."""

    time: list = field(default_factory=list)
    depth_rate: list = field(default_factory=list)
    discharge_rate: list = field(default_factory=list)
    section_discharge: list = field(default_factory=list)
    section_rate: list = field(default_factory=list)
    steps: list = field(default_factory=list)
    wall_time: list = field(default_factory=list)
    converged: bool = False
    tolerance: float = float("nan")
    #: ``run_to_steady(average=True)``: per check, the running mean of the section discharge (m³/s) and its
    #: error (m³/s: batch-means standard error and drift, ``BatchMeans.stats``), NaN below 8 batches; ``averaged``: the run converged on
    #: the mean (the state is then the time mean over ``average_interval`` = (t0, t1) s)
    section_mean: list = field(default_factory=list)
    section_se: list = field(default_factory=list)
    averaged: bool = False
    average_interval: tuple = (math.nan, math.nan)
    #: ``run_to_steady(window=...)``: the window (s; 0 off) and, per check, the section discharge's range over
    #: it and the estimate of its change still to come (m³/s; :func:`window_change_estimate`)
    window: float = 0.0
    window_range: list = field(default_factory=list)
    window_remaining: list = field(default_factory=list)


class SWESimulation:
    """Time marching of one :class:`~breachflow.swe.domain.Domain` (plus extra obstacles) from a cold or warm start.

    *initial* may be a grid snapshot Dataset (warm start: depth, u, v; its water surface is kept where
    the bed changed) or a tuple ``(h, hu, hv)`` of ``(ny, nx)`` arrays. Cells that became obstacles are
    emptied. Without *initial* the domain's ``initial_surface`` (or a dry bed) is used.
    """

    def __init__(self, domain: Domain, options: SWEOptions | None = None, *, obstacles=None, initial=None):
        self.options = options or SWEOptions()
        self.domain = domain if obstacles is None else domain.with_obstacles(_mask(obstacles, domain))
        d = self.domain
        ny, nx = d.shape
        self.dx, self.dy = d.dx, d.dy
        P = K.G
        shape = (ny + 2 * P, nx + 2 * P)
        self.kinds, self.times, self.levels, self.discharges, self.relaxation = pack_boundaries(d)
        self.z = np.zeros(shape)
        self.z[P:-P, P:-P] = d.bed
        self.manning = np.zeros(shape)
        self.manning[P:-P, P:-P] = d.manning
        self.obst = np.zeros(shape, np.int8)
        self.obst[P:-P, P:-P] = d.obstacle
        self._set_porous(d, shape)
        # wall sides: ghost cells flagged as obstacles make their faces reflective
        # discharge inlets: code 2 makes their faces take the prescribed (ghost) state's flux
        wall = np.where(self.kinds == K.BC_WALL, 1, np.where(self.kinds == K.BC_DISCHARGE, 2, 0))
        for layer in range(P):
            self.obst[P:-P, P - 1 - layer] = wall[K.WEST, :ny]
            self.obst[P:-P, P + nx + layer] = wall[K.EAST, :ny]
            self.obst[P - 1 - layer, P:-P] = wall[K.SOUTH, :nx]
            self.obst[P + ny + layer, P:-P] = wall[K.NORTH, :nx]
        self.bed_dz = K.ghost_bed_slopes(self.z, self.obst)
        self.h = np.zeros(shape)
        self.hu = np.zeros(shape)
        self.hv = np.zeros(shape)
        self._work = [np.zeros(shape) for _ in range(6)]
        self.stats = np.array([0.0, np.inf, 0.0, 0.0])  # clipped depth, min / max dt, cell-stages computed
        self.t = 0.0
        self.steps = 0
        self.history = ConvergenceHistory()
        self._set_initial(initial)
        self.outer_velocity = self._initial_outer_velocity()

    # ------------------------------------------------------------------ porous pile (swe/porous.py)
    def _set_porous(self, d, shape):
        """Padded pile arrays; Manning friction is replaced by the pile's law in pile cells."""
        pile = getattr(d, "porous", None)
        self.porous = pile if pile is not None and pile.any else None
        # the pile's resistance is applied inside the time loop (kernels.advance) on the box holding it
        self.pile_box = np.zeros(4, np.int64)
        if self.porous is None:
            self.pile = {k: np.zeros((1, 1)) for k in ("height", "n_free")}
            self.pile.update({k: np.zeros((1, 1, 1)) for k in ("A", "B")})
            return
        P = K.G
        self.pile = {k: np.zeros(shape) for k in ("height", "n_free")}
        self.pile["height"][P:-P, P:-P] = pile.height
        for k in ("A", "B"):  # the layers' coefficients
            layers = getattr(pile, "layer_" + k)
            self.pile[k] = np.zeros(shape + (layers.shape[-1],))
            self.pile[k][P:-P, P:-P] = layers
        self.pile["n_free"][P:-P, P:-P] = d.manning
        self.pile["height"][self.obst != 0] = 0.0
        self.manning[self.pile["height"] > 0] = 0.0
        jj, ii = np.nonzero(self.pile["height"] > 0)
        if jj.size:
            self.pile_box[:] = (jj.min(), jj.max() + 1, ii.min(), ii.max() + 1)

    # ------------------------------------------------------------------ state
    def _set_initial(self, initial):
        d = self.domain
        inner = (slice(K.G, -K.G), slice(K.G, -K.G))
        if initial is None:
            if d.initial_surface is not None:
                h = np.maximum(np.nan_to_num(d.initial_surface - d.bed, nan=0.0), 0.0)
            else:
                h = np.zeros(d.shape)
            hu = np.zeros(d.shape)
            hv = np.zeros(d.shape)
        elif isinstance(initial, xr.Dataset):
            if initial.depth.ndim != 2:
                initial = initial.isel(time=-1)
            if _same_grid(initial, d):
                h0 = np.asarray(initial.depth.values, float)
                if "bed_elevation" in initial:
                    surface = np.asarray(initial.bed_elevation.values, float) + h0
                    h = np.where(h0 > 0, np.maximum(surface - d.bed, 0.0), 0.0)
                else:
                    h = h0
                hu = h * np.asarray(initial.u.values, float)
                hv = h * np.asarray(initial.v.values, float)
            else:
                h, hu, hv = _regrid(initial, d)
        else:
            h, hu, hv = (np.asarray(a, float) for a in initial)
            if h.shape != d.shape:
                raise InputError(f"initial state shape {h.shape} differs from the domain {d.shape}")
        for name, a in (("depth", h), ("hu", hu), ("hv", hv)):
            if not np.all(np.isfinite(a)):
                raise InputError(f"initial {name} has non-finite values")
        if np.any(h < 0):
            raise InputError("initial depth has negative values")
        blocked = d.obstacle
        self.h[inner] = np.where(blocked, 0.0, h)
        self.hu[inner] = np.where(blocked, 0.0, hu)
        self.hv[inner] = np.where(blocked, 0.0, hv)

    def _initial_outer_velocity(self) -> np.ndarray:
        """Outer normal velocity of absorbing level cells: the initial interior one (a warm start
        carries on where it was); NaN elsewhere."""
        u, v = self.velocity()
        inner = {K.WEST: -u[:, 0], K.EAST: u[:, -1], K.SOUTH: -v[0, :], K.NORTH: v[-1, :]}
        out = np.full(self.relaxation.shape, np.nan)
        for side, un in inner.items():
            n = un.size
            absorbing = np.isfinite(self.relaxation[side, :n])
            out[side, :n] = np.where(absorbing, un, np.nan)
        return out

    @property
    def depth(self) -> np.ndarray:
        return self.h[K.G:-K.G, K.G:-K.G]

    @property
    def discharge(self) -> tuple[np.ndarray, np.ndarray]:
        return self.hu[K.G:-K.G, K.G:-K.G], self.hv[K.G:-K.G, K.G:-K.G]

    def velocity(self) -> tuple[np.ndarray, np.ndarray]:
        h = self.depth
        hu, hv = self.discharge
        wet = h > self.options.h_dry
        safe = np.where(wet, h, 1.0)
        return np.where(wet, hu / safe, 0.0), np.where(wet, hv / safe, 0.0)

    def volume(self) -> float:
        """Water volume in the domain (m³)."""
        return float(self.depth.sum() * self.dx * self.dy)

    # ------------------------------------------------------------------ marching
    def advance_to(self, t_end: float, max_steps: int = 10**9) -> "SWESimulation":
        """March to time *t_end* (s). Raises :class:`~breachflow.errors.PhysicsError` on a non-finite state or runaway step."""
        o = self.options
        w = self._work
        previous_threads = numba.get_num_threads()
        if o.threads:
            numba.set_num_threads(max(1, min(int(o.threads), numba.config.NUMBA_NUM_THREADS)))
        pl = self.pile
        try:
            t, steps, status = K.advance(
                self.h, self.hu, self.hv, self.z, self.obst, self.manning, self.bed_dz,
                self.kinds, self.times, self.levels, self.discharges, self.outer_velocity, self.relaxation,
                self.dx, self.dy, o.gravity, o.order == 2, K.LIMITERS[o.limiter], K.RIEMANN[o.riemann],
                o.courant, o.h_dry, float(self.t), float(t_end), int(max_steps), o.dt_min, o.skip_quiet,
                o.quiet_tolerance, numba.get_num_threads(), w[0], w[1], w[2], w[3], w[4], w[5], self.stats,
                pl["height"], pl["A"], pl["B"], pl["n_free"], self.pile_box)
        finally:
            numba.set_num_threads(previous_threads)
        self.t = t
        self.steps += steps
        if status == 2 or not np.all(np.isfinite(self.depth)):
            raise PhysicsError(
                f"shallow-water solver: non-finite state or time step below {o.dt_min} s at t = {t:.6g} s "
                f"(step {self.steps}) in domain {self.domain.name!r}")
        if np.any(self.depth < 0):
            raise PhysicsError(f"shallow-water solver: negative depth at t = {t:.6g} s")
        return self

    def crossing_time(self) -> float:
        """The time (s) a long gravity wave takes to cross the domain along the flow through a section (a
        grid row: the y axis, across the levee of a breach domain): ``L_y / sqrt(g h)``, ``h`` the largest
        depth now (docs/verdict-check.md, *Re-solves that settle*)."""
        d = self.domain
        span = float(d.y[-1] - d.y[0]) + self.dy
        return span / math.sqrt(self.options.gravity * max(float(self.depth.max()), 1e-3))

    def section_discharge(self, section) -> float:
        """Discharge (m³/s) through the breach channel across the grid row nearest ``y`` between ``x0``
        and ``x1``, *section* = ``(x0, x1, y)``, positive towards +y: the closure's breach discharge, the
        same function (:func:`breachflow.swe.section.channel_discharge`: ``Σ h v Δx`` over the open wet
        cells, the median over the channel's rows where walls close the section at both ends), so the
        monitor judges the value the closure reports (issue 16)."""
        x0, x1, y = self._checked_section(section)
        wet = (self.depth > DRY_DEPTH) & ~self.domain.obstacle
        return channel_discharge(self.domain.x, self.domain.y, self.discharge[1], wet, (x0, x1), y)

    def _checked_section(self, section):
        """*section* checked: ``(x0, x1, y)`` as floats, with at least one grid column between x0 and x1."""
        d = self.domain
        try:
            x0, x1, y = (float(v) for v in section)
        except (TypeError, ValueError):
            raise InputError(f"section must be (x0, x1, y) in m, got {section!r}") from None
        if not ((d.x >= x0) & (d.x <= x1)).any():
            raise InputError(f"section {section!r} holds no cell of the domain")
        return x0, x1, y

    def run_to_steady(self, tolerance: float = 1e-4, t_max: float = 3600.0, check_interval: float | None = None,
                      min_time: float = 0.0, region=None, progress=None, section=None,
                      average: bool = False, window: float | str | None = None,
                      window_change: float = WINDOW_CHANGE) -> ConvergenceHistory:
        """March until the relative rates of change of depth and discharge fall below *tolerance* (1/s).

        Rates over each check interval Δt: ``sum|h - h_prev| / (sum h Δt)`` and the same with the
        discharge magnitude, summed over the cells of *region* (a boolean mask; default all cells —
        e.g. the breach vicinity when only the flow there matters). While the region is dry its rates say
        nothing (the flood may not have reached it yet): the depth rate of the whole domain must then be below
        *tolerance* too. With *section* ``(x0, x1, y)``
        (the breach: :meth:`section_discharge`) its discharge Q must settle too:
        ``|Q - Q_prev| / (max(|Q|, |Q_prev|) Δt) < tolerance``. Stops at *t_max* (s) of simulated time
        otherwise (``converged`` False). *progress(sim, history)* is called after each check interval.

        *average* (needs *section*): a flow that sheds eddies never settles, so also accept the running
        mean of Q (:class:`~breachflow.swe.steady_mean.BatchMeans`, Q sampled 8 times per check interval):
        converged when its error (standard error and drift, ``BatchMeans.stats``) is at most
        ``tolerance × check_interval`` of it (the relative change the rate test accepts over one interval)
        with at least 8 batches (of at least one check interval each) and no drift between the
        first and second half of the batches (else the first half is dropped as a transient); the first half
        of the record is always left out as the start-up transient. The state
        is then the time mean of depth and unit discharges over the averaging interval
        (``history.averaged``, ``history.average_interval``); ``history.section_mean`` / ``section_se``
        record the running mean and its standard error per check. A flow that does settle converges on
        the rate test as without *average*.

        *window* (s, ``"auto"`` for :meth:`crossing_time`, None or 0: off; needs *section*): a warm start
        from a nearby steady state passes the rate test after one check interval even when the flow has only
        begun a slow change (a jet or hydraulic jump moving, the pools on both sides re-levelling, a wave
        from a boundary not yet at the section), which takes about one long-wave crossing of the domain to
        show. The run then also needs at least *window*
        s of marching, and the section discharge must have stayed within ``window_change`` (relative, default
        :data:`WINDOW_CHANGE`) over the last *window* s, and its change still to come, extrapolated from the
        window's two halves, must be as small (:func:`window_change_estimate`; ``history.window``,
        ``history.window_range``, ``history.window_remaining``). docs/verdict-check.md, *Re-solves that
        settle*.
        """
        sel = np.ones(self.domain.shape, bool) if region is None else _mask(region, self.domain)
        if not sel.any():
            raise InputError("run_to_steady: the monitoring region is empty")
        if not tolerance > 0:
            raise InputError(f"steady-state tolerance must be > 0, got {tolerance}")
        if not t_max > 0:
            raise InputError(f"t_max must be > 0 s, got {t_max}")
        if section is not None:
            self._checked_section(section)  # checked before the run
        elif window:
            raise InputError("run_to_steady: a steady window needs the section whose discharge it watches")
        elif average:
            raise InputError("run_to_steady: average=True needs the section whose discharge is averaged")
        if check_interval is None:
            # a few gravity-wave crossings of a cell band: 20 cells at the fastest wave speed, at least 1 s
            hmax = max(float(self.depth.max()), float(np.nanmax(self.levels)) - float(self.domain.bed.min())
                       if np.isfinite(self.levels).any() else 0.0, 1e-3)
            check_interval = max(1.0, 20.0 * min(self.dx, self.dy) / math.sqrt(self.options.gravity * hmax))
        if window == "auto":
            window = self.crossing_time()
        window = float(window or 0.0)
        if not (window >= 0.0 and math.isfinite(window)):
            raise InputError(f"steady window must be a time >= 0 s or 'auto', got {window!r}")
        if not 0.0 < window_change < 1.0:
            raise InputError(f"window_change must be in (0, 1), got {window_change!r}")
        hist = self.history
        hist.tolerance = tolerance
        hist.window = window
        t_start = self.t
        q_begin = self.section_discharge(section) if window > 0.0 else math.nan  # the window's first value
        n_hist0 = len(hist.time)
        wall0 = _time.perf_counter()
        h_prev = self.depth[sel]
        # the whole domain's depth, kept only while the monitoring region is dry (below)
        h_all_prev = None if (h_prev > 0).any() else self.depth.copy()
        q_prev = np.hypot(*self.discharge)[sel]
        qs_prev = self.section_discharge(section) if section is not None else math.nan
        n_sub = 8 if average else 1
        acc = BatchMeans(n_sub) if average else None
        inner = (slice(K.G, -K.G), slice(K.G, -K.G))
        while self.t < t_start + t_max - 1e-12:
            t0 = self.t
            if acc is None:
                self.advance_to(min(self.t + check_interval, t_start + t_max))
            else:
                for k in range(n_sub):
                    self.advance_to(min(t0 + (k + 1) * check_interval / n_sub, t_start + t_max))
                    acc.add(self.t, self.section_discharge(section), (self.h[inner], self.hu[inner], self.hv[inner]))
                    if self.t >= t_start + t_max - 1e-12:
                        break
            dt = self.t - t0
            h = self.depth[sel]
            q = np.hypot(*self.discharge)[sel]
            rate_h = float(np.abs(h - h_prev).sum() / (max(h.sum(), 1e-300) * dt))
            rate_q = float(np.abs(q - q_prev).sum() / (max(q.sum(), 1e-300) * dt)) if q.sum() > 0 else 0.0
            # a dry monitoring region has nothing to change yet: it is steady only when the whole domain is (the
            # flood may still be on its way to the breach)
            rate_dry = 0.0
            if not (h > 0).any():
                h_all = self.depth.copy()
                rate_dry = (math.inf if h_all_prev is None else
                            float(np.abs(h_all - h_all_prev).sum() / (max(h_all.sum(), 1e-300) * dt)))
                h_all_prev = h_all
            else:
                h_all_prev = None
            rate_s = 0.0
            qs = math.nan
            if section is not None:
                qs = self.section_discharge(section)
                scale = max(abs(qs), abs(qs_prev))
                rate_s = abs(qs - qs_prev) / (scale * dt) if scale > 0 else 0.0
            hist.time.append(self.t)
            hist.depth_rate.append(rate_h)
            hist.discharge_rate.append(rate_q)
            hist.section_discharge.append(qs)
            hist.section_rate.append(rate_s if section is not None else math.nan)
            hist.steps.append(self.steps)
            hist.wall_time.append(_time.perf_counter() - wall0)
            h_prev = h
            q_prev = q
            qs_prev = qs
            mean_ok = False
            if acc is not None:
                acc.drop_before(t_start + 0.5 * (self.t - t_start))  # the first half of the record: warm-up
                if acc.drifting():
                    acc.drop_first_half()
                mean, se = acc.stats() if acc.batches >= 8 else (math.nan, math.nan)
                hist.section_mean.append(mean)
                hist.section_se.append(se)
                mean_ok = se <= tolerance * check_interval * abs(mean)  # False while NaN
            if progress is not None:
                progress(self, hist)
            settled = rate_h < tolerance and rate_q < tolerance and rate_s < tolerance and rate_dry < tolerance
            held = True
            if window > 0.0:
                rng, remaining = window_change_estimate(hist.time[n_hist0:], hist.section_discharge[n_hist0:],
                                                        t_start, q_begin, window)
                hist.window_range.append(rng)
                hist.window_remaining.append(remaining)
                held = max(rng, remaining) <= window_change * abs(qs)
            if self.t - t_start >= max(min_time, window - 1e-9) and (settled or mean_ok) and held:
                hist.converged = True
                if not settled:
                    hist.averaged = True
                    hist.average_interval = acc.interval()
                    self.h[inner], self.hu[inner], self.hv[inner] = acc.mean_fields()
                break
        return hist

    # ------------------------------------------------------------------ output
    def snapshot(self, *, source: str = "breachflow shallow-water solver (swe)", derived: bool = True,
                 **derived_kwargs) -> xr.Dataset:
        """The grid snapshot Dataset (schema data_schemas/snapshot_grid.json) with derived fields and the convergence history."""
        d = self.domain
        h = self.depth.copy()
        u, v = self.velocity()
        extra = {}
        if derived:
            fields = _derived.derived_fields(d.bed, h, u, v, d.manning, g=self.options.gravity, **derived_kwargs)
            extra.update({k: (("y", "x"), a, attrs) for k, (a, attrs) in fields.items()})
        hist = self.history
        if hist.time:
            extra["convergence_time"] = (("convergence_check",), np.array(hist.time),
                                         {"long_name": "simulated time of the steady-state check", "units": "s"})
            extra["convergence_depth_rate"] = (("convergence_check",), np.array(hist.depth_rate),
                                               {"long_name": "relative rate of change of depth (L1)", "units": "s-1"})
            extra["convergence_discharge_rate"] = (("convergence_check",), np.array(hist.discharge_rate),
                                                   {"long_name": "relative rate of change of unit discharge (L1)", "units": "s-1"})
            if np.isfinite(hist.section_discharge).any():
                extra["convergence_section_discharge"] = (
                    ("convergence_check",), np.array(hist.section_discharge),
                    {"long_name": "discharge through the monitored section (breach)", "units": "m3 s-1"})
        ds = grid_snapshot(d.x, d.y, d.bed, h, u, v, obstacle=d.obstacle.astype("i1"), crs_wkt=d.crs_wkt,
                           source=source, extra=extra)
        o = self.options
        ds.attrs.update(
            solver="swe", solver_order=o.order, solver_courant=o.courant, solver_limiter=o.limiter,
            solver_riemann=o.riemann, simulated_time_s=float(self.t), time_steps=int(self.steps),
            steady_state=int(hist.converged), steady_state_tolerance_per_s=float(hist.tolerance),
            domain=d.name,
        )
        return ds


def window_change_estimate(times, q, t_start: float, q0: float, window: float) -> tuple[float, float]:
    """``(range, remaining)`` (m³/s) of the section discharge *q* at check *times* over the last *window* s
    of a run that began at *t_start* from discharge *q0*.

    *range* is ``max - min`` over the checks in ``[t - W, t]`` (with the values at both ends interpolated
    linearly between checks). *remaining* estimates how far the discharge still has to go: from the values
    ``Q0, Q1, Q2`` at ``t - W``, ``t - W/2`` and ``t``, with ``d1 = Q1 - Q0`` and ``d2 = Q2 - Q1`` of one sign
    (a monotone approach) the change still to come of a geometric (exponential) approach,
    ``|d2| r / (1 - r)`` with ``r = d2 / d1`` (Aitken's Δ² extrapolation); when the change does not slow
    down (``r >= 1``: a slow start, the flow only beginning to move, or a creep) the change of one more
    window at the pace of its second half, ``2 |d2|``; without one sign (an oscillation, or no change)
    half the range."""
    t = np.append(t_start, np.asarray(times, float))
    v = np.append(q0 if np.isfinite(q0) else q[0], np.asarray(q, float))
    now = t[-1]
    if now - t_start < window - 1e-9:
        return math.inf, math.inf
    q_start, q_mid = np.interp([now - window, now - 0.5 * window], t, v)
    inside = v[t > now - window + 1e-9]
    vals = np.concatenate([[q_start], inside])
    rng = float(vals.max() - vals.min())
    d1, d2 = q_mid - q_start, v[-1] - q_mid
    if d1 * d2 > 0:
        r = d2 / d1
        remaining = 2.0 * abs(d2) if r >= 1.0 else abs(d2) * r / (1.0 - r)
    else:
        remaining = 0.5 * rng
    return rng, float(remaining)


def _same_grid(snapshot: xr.Dataset, domain: Domain) -> bool:
    if snapshot.depth.shape != domain.shape:
        return False
    return bool(np.allclose(snapshot.x.values, domain.x) and np.allclose(snapshot.y.values, domain.y))


def _regrid(snapshot: xr.Dataset, domain: Domain):
    """Warm start from a snapshot on another grid (grid sequencing: a coarse steady state starts a fine
    run). The wet-weighted bilinear interpolation of surface and velocity (normalised convolution, so
    dry cells do not drag the surface down) is laid on the new bed, which keeps a lake at rest at rest."""
    for name in ("depth", "u", "v", "bed_elevation"):
        if name not in snapshot:
            raise InputError(f"warm start from another grid: the snapshot has no {name!r} variable")
    if snapshot.depth.dims != ("y", "x"):
        raise InputError(f"warm start from another grid needs a (y, x) grid snapshot, got dims {snapshot.depth.dims}")
    from scipy.interpolate import RegularGridInterpolator

    wet = snapshot.depth > 0
    src = (snapshot.y.values, snapshot.x.values)
    Y, X = np.meshgrid(domain.y, domain.x, indexing="ij")

    def on_new(a):  # bilinear, extrapolated linearly over the half cell outside the source centres
        return RegularGridInterpolator(src, np.asarray(a, float), bounds_error=False, fill_value=None)((Y, X))

    w = on_new(wet)
    wet_new = w > 1e-9     # any wet source cell around: its surface, laid on the new bed, decides
    safe = np.where(wet_new, w, 1.0)
    eta = on_new((snapshot.bed_elevation + snapshot.depth).where(wet, 0.0)) / safe
    h = np.where(wet_new, np.maximum(eta - domain.bed, 0.0), 0.0)
    return h, h * on_new(snapshot.u.where(wet, 0.0)) / safe, h * on_new(snapshot.v.where(wet, 0.0)) / safe


def _mask(obstacles, domain: Domain) -> np.ndarray:
    if isinstance(obstacles, xr.DataArray):
        obstacles = obstacles.values
    if isinstance(obstacles, xr.Dataset):
        obstacles = obstacles["obstacle"].values
    m = np.asarray(obstacles, dtype=bool)
    if m.shape != domain.shape:
        raise InputError(f"obstacles: mask shape {m.shape} differs from the domain {domain.shape}")
    return m


class SWESolver:
    """The embedded solver as a :class:`~breachflow.hydro.solvers.HydroSolver`: solves to steady state.

    ``solve(domain, obstacles=None, initial=None)`` returns the snapshot Dataset; the last
    :class:`SWESimulation` is kept as ``last`` (its ``history`` is the convergence history).
    *region*, *section*, *average*, *window* and *window_change* are those of
    :meth:`SWESimulation.run_to_steady` (the window only with a section).
    """

    def __init__(self, order: int = 2, courant: float = 0.45, limiter: str = "minmod", riemann: str = "hllc",
                 tolerance: float = 1e-4, t_max: float = 3600.0, check_interval: float | None = None,
                 h_dry: float = 1e-8, threads: int | None = 1, region=None, section=None, average: bool = False,
                 window: float | str | None = None, window_change: float = WINDOW_CHANGE, **derived_kwargs):
        self.options = SWEOptions(order=order, courant=courant, limiter=limiter, riemann=riemann, h_dry=h_dry,
                                  threads=threads)
        self.region = region
        self.section = section
        self.average = bool(average)
        self.window, self.window_change = window, window_change
        self.tolerance = tolerance
        self.t_max = t_max
        self.check_interval = check_interval
        self.derived_kwargs = derived_kwargs
        self.last: SWESimulation | None = None

    def solve(self, domain: Domain, obstacles=None, initial=None) -> xr.Dataset:
        sim = SWESimulation(domain, self.options, obstacles=obstacles, initial=initial)
        sim.run_to_steady(self.tolerance, self.t_max, self.check_interval, region=self.region, section=self.section,
                          average=self.average, window=self.window if self.section is not None else None,
                          window_change=self.window_change)
        self.last = sim
        return sim.snapshot(**self.derived_kwargs)
