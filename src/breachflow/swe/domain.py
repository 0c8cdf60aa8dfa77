"""The domain a hydrodynamic solver takes, and the terrain builder of a levee breach (docs/theory.md, *Breach growth*, *Shallow-water equations*).

A :class:`Domain` is a structured grid of square-or-rectangular cells (cell-centre coordinates in m),
bed elevation, Manning's n and obstacle (no-flow) mask per cell, boundary conditions per side and an
optional initial water surface. :func:`breach_domain` builds one for a
:class:`~breachflow.scenario.geometry.BreachScene` (e.g. the report's ``typical_breach()``).

Scene coordinates: the levee centreline is ``y = 0``, flood side ``y < 0``, protected side ``y > 0``,
breach centred at ``x = 0``; the flood channel runs along x from ``x0`` (upstream) to ``x1``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Callable, Sequence

import numpy as np

from ..errors import InputError

SIDES = ("west", "east", "south", "north")
KINDS = ("outflow", "wall", "level", "discharge")


@dataclass(frozen=True)
class BoundaryCondition:
    """One boundary condition on (a stretch of) one side of the grid.

    ``kind``: ``"wall"`` (reflective, no flow), ``"outflow"`` (free / transmissive), ``"level"``
    (prescribed water-surface elevation, m; velocity extrapolated from inside) or ``"discharge"``
    (prescribed unit discharge into the domain, m²/s; depth from inside — subcritical — or from
    ``level`` when both are given — supercritical inflow).

    ``level`` / ``discharge`` may be a constant, an array with one value per boundary cell of the
    stretch, a callable of the along-side coordinate ``s`` (m, x for south/north, y for west/east),
    or — with ``times`` (s) — an array ``(len(times),)`` (a time series, uniform along the side) or
    ``(len(times), n_cells)``. ``start``/``stop`` (m, along-side coordinate) limit the stretch.

    ``absorbing`` (s, level boundaries only): an exactly imposed level reflects every wave (the level
    is a node of the surface), so a basin between it and a wall rings for hours. With a relaxation
    time T the incoming Riemann invariant is taken from water at the prescribed level moving with the
    interior's normal velocity averaged over T: waves much shorter than T leave the domain, and in a
    steady state the boundary stage is still the prescribed level.
    """

    kind: str
    level: object = None
    discharge: object = None
    times: object = None
    start: float | None = None
    stop: float | None = None
    absorbing: float | None = None

    def __post_init__(self):
        if self.kind not in KINDS:
            raise InputError(f"boundary condition kind {self.kind!r} unknown; use one of {KINDS}")
        if self.kind == "level" and self.level is None:
            raise InputError("boundary condition 'level' needs level=")
        if self.absorbing is not None and (self.kind != "level" or not self.absorbing > 0):
            raise InputError(f"absorbing= takes a relaxation time > 0 s on a 'level' boundary, got "
                             f"{self.absorbing!r} on {self.kind!r}")
        if self.kind == "discharge" and self.discharge is None:
            raise InputError("boundary condition 'discharge' needs discharge=")

    @classmethod
    def wall(cls, start=None, stop=None) -> "BoundaryCondition":
        return cls("wall", start=start, stop=stop)

    @classmethod
    def outflow(cls, start=None, stop=None) -> "BoundaryCondition":
        return cls("outflow", start=start, stop=stop)

    @classmethod
    def water_level(cls, level, times=None, start=None, stop=None, absorbing=None) -> "BoundaryCondition":
        return cls("level", level=level, times=times, start=start, stop=stop, absorbing=absorbing)

    @classmethod
    def inflow(cls, discharge, level=None, times=None, start=None, stop=None) -> "BoundaryCondition":
        return cls("discharge", discharge=discharge, level=level, times=times, start=start, stop=stop)

    def values(self, which: str, s: np.ndarray, times_out: np.ndarray) -> np.ndarray:
        """Value (``which`` = "level" or "discharge") at the cells ``s`` for each time of ``times_out``."""
        val = getattr(self, which)
        n = s.size
        if val is None:
            return np.full((times_out.size, n), np.nan)
        if callable(val):
            prof = np.asarray(val(s), dtype=float) * np.ones(n)
            out = np.broadcast_to(prof, (times_out.size, n)).copy()
        elif self.times is None:
            arr = np.asarray(val, dtype=float)
            if arr.ndim == 0:
                arr = np.full(n, float(arr))
            if arr.shape != (n,):
                raise InputError(f"boundary {which}: {arr.size} values for {n} boundary cells")
            out = np.broadcast_to(arr, (times_out.size, n)).copy()
        else:
            t = np.asarray(self.times, dtype=float)
            arr = np.asarray(val, dtype=float)
            if t.ndim != 1 or t.size == 0 or np.any(np.diff(t) <= 0):
                raise InputError(f"boundary {which}: times must be strictly increasing")
            if arr.ndim == 1:
                arr = arr[:, None] * np.ones(n)
            if arr.shape != (t.size, n):
                raise InputError(f"boundary {which}: time series shape {arr.shape}, expected ({t.size}, {n})")
            out = np.empty((times_out.size, n))
            for k in range(n):
                out[:, k] = np.interp(times_out, t, arr[:, k])
        if not np.all(np.isfinite(out)):
            raise InputError(f"boundary {which}: values are not finite")
        return out


@dataclass
class Domain:
    """Structured-grid domain: cell centres ``x`` (nx,), ``y`` (ny,), fields shaped ``(ny, nx)``.

    ``boundaries`` maps a side (``west`` = x min, ``east``, ``south`` = y min, ``north``) to a list of
    :class:`BoundaryCondition`; later entries override earlier ones on their stretch; sides not given
    are walls. ``initial_surface`` (water-surface elevation, m; NaN or below the bed = dry) is the cold
    start state.
    """

    x: np.ndarray
    y: np.ndarray
    bed: np.ndarray
    manning: np.ndarray | float = 0.0
    obstacle: np.ndarray | None = None
    boundaries: dict = field(default_factory=dict)
    initial_surface: np.ndarray | None = None
    name: str = ""
    crs_wkt: str | None = None
    #: a porous rock pile (:class:`breachflow.swe.porous.PorousPile`) flowed through with
    #: Forchheimer resistance by the ``swe`` solver; None = none
    porous: object | None = None

    def __post_init__(self):
        self.x = np.asarray(self.x, dtype=float)
        self.y = np.asarray(self.y, dtype=float)
        if self.x.ndim != 1 or self.y.ndim != 1 or self.x.size < 1 or self.y.size < 1:
            raise InputError("Domain: x and y must be 1-D cell-centre coordinates")
        for name, c in (("x", self.x), ("y", self.y)):
            if c.size > 1:
                d = np.diff(c)
                if np.any(d <= 0) or not np.allclose(d, d[0], rtol=1e-9, atol=0):
                    raise InputError(f"Domain: {name} must be uniformly spaced and increasing")
        shape = self.shape
        self.bed = np.array(np.broadcast_to(np.asarray(self.bed, dtype=float), shape))
        if not np.all(np.isfinite(self.bed)):
            raise InputError("Domain: bed elevation has non-finite values")
        self.manning = np.array(np.broadcast_to(np.asarray(self.manning, dtype=float), shape))
        if not np.all(np.isfinite(self.manning)) or np.any(self.manning < 0):
            raise InputError("Domain: Manning's n must be finite and >= 0")
        self.obstacle = (np.zeros(shape, bool) if self.obstacle is None
                         else np.array(np.broadcast_to(np.asarray(self.obstacle, dtype=bool), shape)))
        unknown = set(self.boundaries) - set(SIDES)
        if unknown:
            raise InputError(f"Domain: unknown boundary side(s) {sorted(unknown)}; use {SIDES}")
        self.boundaries = {k: ([v] if isinstance(v, BoundaryCondition) else list(v)) for k, v in self.boundaries.items()}
        if self.initial_surface is not None:
            self.initial_surface = np.array(np.broadcast_to(np.asarray(self.initial_surface, dtype=float), shape))

    @property
    def shape(self) -> tuple[int, int]:
        return (self.y.size, self.x.size)

    @property
    def dx(self) -> float:
        return float(self.x[1] - self.x[0]) if self.x.size > 1 else self._single_spacing("x")

    @property
    def dy(self) -> float:
        return float(self.y[1] - self.y[0]) if self.y.size > 1 else self._single_spacing("y")

    def _single_spacing(self, axis):
        sp = getattr(self, "_spacing_" + axis, None)
        if sp is None:
            raise InputError(f"Domain: a single-cell {axis} axis needs an explicit spacing (use uniform_grid)")
        return sp

    def with_obstacles(self, mask) -> "Domain":
        """A copy with more no-flow cells (logical or with *mask*)."""
        d = replace(self, obstacle=self.obstacle | np.asarray(mask, dtype=bool))
        _copy_spacing(self, d)
        return d

    def with_raised_bed(self, mask, elevation) -> "Domain":
        """A copy whose bed is raised to at least *elevation* (scalar or array) on *mask* (closure edits)."""
        mask = np.asarray(mask, dtype=bool)
        bed = self.bed.copy()
        target = np.broadcast_to(np.asarray(elevation, dtype=float), bed.shape)
        bed[mask] = np.maximum(bed[mask], target[mask])
        d = replace(self, bed=bed)
        _copy_spacing(self, d)
        return d

    def with_porous(self, pile) -> "Domain":
        """A copy with the porous pile *pile* (a ``PorousPile`` of this shape, or None)."""
        if pile is not None and np.shape(pile.height) != self.shape:
            raise InputError(f"Domain: porous pile shape {np.shape(pile.height)} differs from {self.shape}")
        d = replace(self, porous=pile)
        _copy_spacing(self, d)
        return d

    def cell_index(self, px, py):
        """(j, i) indices of the cells containing points (px, py)."""
        i = np.floor((np.asarray(px) - self.x[0]) / self.dx + 0.5).astype(int)
        j = np.floor((np.asarray(py) - self.y[0]) / self.dy + 0.5).astype(int)
        return j, i


def _copy_spacing(src, dst):
    for a in ("x", "y"):
        sp = getattr(src, "_spacing_" + a, None)
        if sp is not None:
            setattr(dst, "_spacing_" + a, sp)


def uniform_grid(x0: float, x1: float, y0: float, y1: float, dx: float, dy: float | None = None, **kwargs) -> Domain:
    """A :class:`Domain` covering ``[x0, x1] × [y0, y1]`` (m) with cells of ``dx × dy``.

    The number of cells is ``round((x1 - x0) / dx)``; the spacing is adjusted to fit the extent exactly.
    ``bed`` may be a callable ``bed(X, Y)`` of the cell-centre meshgrid; other keywords go to Domain.
    """
    dy = dx if dy is None else dy
    if not (x1 > x0 and y1 > y0 and dx > 0 and dy > 0):
        raise InputError(f"uniform_grid: empty extent or spacing ({x0}, {x1}, {y0}, {y1}, {dx}, {dy})")
    nx_f, ny_f = round((x1 - x0) / dx), round((y1 - y0) / dy)
    from ..limits import check_grid_size

    check_grid_size(nx_f, ny_f, dx, dy, (x0, x1, y0, y1))  # before anything of that size is allocated
    nx = max(1, int(nx_f))
    ny = max(1, int(ny_f))
    ddx = (x1 - x0) / nx
    ddy = (y1 - y0) / ny
    x = x0 + (np.arange(nx) + 0.5) * ddx
    y = y0 + (np.arange(ny) + 0.5) * ddy
    X, Y = np.meshgrid(x, y)
    for key in ("bed", "manning", "initial_surface", "obstacle"):
        if callable(kwargs.get(key)):
            kwargs[key] = kwargs[key](X, Y)
    kwargs.setdefault("bed", 0.0)
    dom = Domain(x=x, y=y, **kwargs)
    dom._spacing_x = ddx
    dom._spacing_y = ddy
    return dom


# ----------------------------------------------------------------------------------------------------
# levee breach terrain


def levee_bed(scene, X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """Bed elevation of the breach scene at points (X, Y) (m above datum).

    Ground ``z_g`` on the flood side; the polder falls away from the levee toe at ``polder_slope``;
    the trapezoidal levee (crest ``z_g + h_L``, crown ``b``, slopes 1V:m_F H / 1V:m_P H) is cut by the
    breach (length B at the crest, walls 1V:m_W H, bottom D below the crest, scour d_S below ground).
    """
    lev = scene.levee
    br = scene.breach
    zg = scene.ground_elevation
    crest = zg + lev.height
    half_b = 0.5 * lev.crown_width
    toe_p = half_b + lev.height * lev.protected_slope
    bed = np.full(np.shape(X), zg, dtype=float)
    polder = Y > toe_p
    bed[polder] = zg - (Y[polder] - toe_p) * scene.polder_slope
    # levee section: height above ground as a function of y
    up_f = np.clip((Y + half_b + lev.height * lev.flood_slope) / max(lev.height * lev.flood_slope, 1e-12), 0, 1) if lev.flood_slope > 0 else (Y >= -half_b).astype(float)
    up_p = np.clip((toe_p - Y) / max(lev.height * lev.protected_slope, 1e-12), 0, 1) if lev.protected_slope > 0 else (Y <= half_b).astype(float)
    section = lev.height * np.minimum(up_f, up_p)
    section = np.where((Y >= -half_b - lev.height * lev.flood_slope) & (Y <= toe_p), section, 0.0)
    # breach cut: crest-level elevation of the cut floor as a function of |x|
    half_bottom = 0.5 * br.bottom_width
    cut_floor = crest - br.depth - br.scour_depth
    ax = np.abs(X)
    if br.wall_slope > 0:
        cut = cut_floor + np.clip((ax - half_bottom) / br.wall_slope, 0.0, None)
    else:
        cut = np.where(ax <= half_bottom, cut_floor, np.inf)
    footprint = (Y >= -half_b - lev.height * lev.flood_slope) & (Y <= toe_p)
    bed = np.where(footprint, np.minimum(bed + section, cut), bed)
    return bed


def levee_obstacle(scene, X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """The intact levee as a no-flow region at points (X, Y): its footprint (toe to toe) outside the
    breach, ``|x| > B/2`` (the report's ADH model; :func:`breach_domain` with ``levee_no_flow``)."""
    lev = scene.levee
    half_b = 0.5 * lev.crown_width
    toe_f = -(half_b + lev.height * lev.flood_slope)
    toe_p = half_b + lev.height * lev.protected_slope
    X, Y = np.asarray(X, float), np.asarray(Y, float)
    return (Y >= toe_f) & (Y <= toe_p) & (np.abs(X) > 0.5 * scene.breach.length)


def breach_terrain(scene, *, levee_no_flow: bool = True):
    """The scene's terrain as a function of position, ``terrain(X, Y) -> (bed, obstacle)``: the analytic bed
    (:func:`levee_bed`) and, with *levee_no_flow*, the intact levee's no-flow region (:func:`levee_obstacle`)
    at any points — the terrain a nested grid takes at its own cells instead of interpolating a coarser
    grid's bed (:func:`breachflow.hydro.nested.nested_domain`, ``terrain``)."""

    def terrain(X, Y):
        X, Y = np.asarray(X, float), np.asarray(Y, float)
        obstacle = levee_obstacle(scene, X, Y) if levee_no_flow else np.zeros(X.shape, bool)
        return levee_bed(scene, X, Y), obstacle

    return terrain


def breach_domain(scene, resolution: float, *, levee_no_flow: bool = True, flood_level_profile: bool = True,
                  absorbing_source: bool = True) -> Domain:
    """Structured-grid :class:`Domain` of a :class:`~breachflow.scenario.geometry.BreachScene` at *resolution* (m).

    Extent: the levee length (``2 L_side + B``) along x, ``flood_side_extent`` to
    ``protected_side_extent`` across. Boundary conditions (report §3.2.1, Fig 3.2): the flood source is
    a prescribed water level on the flood-side edge and on the flood-side parts of the channel ends,
    equal to the flood elevation at the upstream end and falling linearly by ``flood_channel_drop``
    over ``flood_channel_length`` downstream; the polder edges drain freely. With ``absorbing_source``
    the source level is absorbing (relaxation time ``4 L / sqrt(g h_L)``, the period of the quarter-wave
    seiche between levee and source, L the flood-side extent): an exactly imposed level reflects the
    waves of the breach opening and the flood-side basin would ring for hours (report's ADH runs reach
    their steady state on the same mean levels). With ``levee_no_flow`` the
    intact levee outside the breach is a no-flow boundary (the report's ADH model) instead of bed.
    Initial state: flood side at the source level, polder dry.
    """
    if not resolution > 0:
        raise InputError(f"resolution must be > 0 m, got {resolution}")
    lev = scene.levee
    relaxation = None
    if absorbing_source:
        relaxation = 4.0 * scene.flood_side_extent / math.sqrt(9.81 * max(lev.height, 1e-3))

    def source(level, start=None, stop=None):
        return BoundaryCondition.water_level(level, start=start, stop=stop, absorbing=relaxation)

    half_len = scene.levee_length_each_side + 0.5 * scene.breach.length
    x0, x1 = -half_len, half_len
    y0, y1 = -scene.flood_side_extent, scene.protected_side_extent
    nx = int(round((x1 - x0) / resolution))
    ny = int(round((y1 - y0) / resolution))
    if nx < 4 or ny < 4:
        raise InputError(f"resolution {resolution} m is too coarse for the scene ({nx} × {ny} cells)")
    dom = uniform_grid(x0, x1, y0, y1, (x1 - x0) / nx, (y1 - y0) / ny)
    X, Y = np.meshgrid(dom.x, dom.y)
    bed = levee_bed(scene, X, Y)

    def level_at(x):
        if not flood_level_profile:
            return np.full(np.shape(x), scene.flood_water_elevation)
        frac = (np.asarray(x, dtype=float) - x0) / scene.flood_channel_length
        return scene.flood_water_elevation - scene.flood_channel_drop * frac

    half_b = 0.5 * lev.crown_width
    toe_f = -(half_b + lev.height * lev.flood_slope)
    obstacle = np.zeros(dom.shape, bool)
    if levee_no_flow:
        obstacle = levee_obstacle(scene, X, Y)
        # at least one blocked cell per column so that the levee is watertight at any resolution
        jc = int(np.argmin(np.abs(dom.y)))
        obstacle[jc, np.abs(dom.x) > 0.5 * scene.breach.length] = True
    initial = np.where(Y < 0.0, level_at(X), np.nan)
    dom.bed = bed
    dom.manning = np.full(dom.shape, scene.manning_n)
    dom.obstacle = obstacle
    dom.initial_surface = initial
    dom.name = scene.name or "breach"
    dom.boundaries = {
        "south": [source(level_at)],
        "west": [BoundaryCondition.outflow(), source(float(level_at(x0)), start=y0, stop=toe_f)],
        "east": [BoundaryCondition.outflow(), source(float(level_at(x1)), start=y0, stop=toe_f)],
        "north": [BoundaryCondition.outflow()],
    }
    return dom


def pack_boundaries(domain: Domain):
    """Arrays for the numba kernels: ``kinds (4, nmax) int8``, ``times (nt,)``,
    ``levels, discharges (4, nt, nmax)`` and ``relaxation (4, nmax)``, the relaxation time (s) of
    absorbing level cells (NaN elsewhere)."""
    from .kernels import BC_DISCHARGE, BC_LEVEL, BC_OUTFLOW, BC_WALL

    code = {"outflow": BC_OUTFLOW, "wall": BC_WALL, "level": BC_LEVEL, "discharge": BC_DISCHARGE}
    ny, nx = domain.shape
    nmax = max(nx, ny)
    coords = {"west": domain.y, "east": domain.y, "south": domain.x, "north": domain.x}
    all_times = sorted({float(t) for bcs in domain.boundaries.values() for bc in bcs if bc.times is not None
                        for t in np.atleast_1d(np.asarray(bc.times, dtype=float))})
    times = np.array(all_times if all_times else [0.0])
    kinds = np.full((4, nmax), BC_WALL, dtype=np.int8)
    levels = np.full((4, times.size, nmax), np.nan)
    discharges = np.zeros((4, times.size, nmax))
    relaxation = np.full((4, nmax), np.nan)
    for side_index, side in enumerate(SIDES):
        s = coords[side]
        for bc in domain.boundaries.get(side, []):
            sel = np.ones(s.size, bool)
            if bc.start is not None:
                sel &= s >= bc.start
            if bc.stop is not None:
                sel &= s <= bc.stop
            if not sel.any():
                continue
            idx = np.nonzero(sel)[0]
            kinds[side_index, idx] = code[bc.kind]
            relaxation[side_index, idx] = np.nan if bc.absorbing is None else float(bc.absorbing)
            lv = bc.values("level", s[idx], times)
            levels[side_index][:, idx] = lv
            if bc.kind == "discharge":
                dq = bc.values("discharge", s[idx], times)
                discharges[side_index][:, idx] = dq
    return kinds, times, levels, discharges, relaxation


def breach_vicinity(domain: Domain, scene, radius: float | None = None) -> np.ndarray:
    """Mask of the cells within *radius* (m) of the breach centre (0, 0): where the closure acts.

    Default radius: twice the breach length, the reach of the approach and jet flows the dropped
    masses meet (beyond it, slow eddies of the flood channel decide nothing about the closure).
    """
    if radius is None:
        radius = 2.0 * scene.breach.length
    if not radius > 0:
        raise InputError(f"breach vicinity radius must be > 0 m, got {radius}")
    X, Y = np.meshgrid(domain.x, domain.y)
    return np.hypot(X, Y) <= radius
