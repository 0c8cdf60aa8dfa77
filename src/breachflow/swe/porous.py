"""Flow through a porous rock pile in the depth-averaged solver: a Forchheimer source term.

Scheme (one column per cell, chosen for a depth-averaged model). In a pile cell the bed stays the
natural bed; the pile occupies the water column from the bed up to its top ``H`` (the cell's highest unit
top), ``min(H, h)`` of the depth ``h``; above it a free layer ``h - H`` flows over the crest. The column is
cut into ``K`` layers of equal thickness ``H / K``, each with its own porosity ``n_k``: the share of the
layer's volume (the whole cell's area times its thickness) not taken by the units. Units are round and
their tops uneven, so a cell larger than a unit (2 m units on 4 m cells) holds a dense core low down and
sparse crowns with open water between them near its top; one porosity for the whole column (``K = 1``)
counted the open water between the crowns as pores of the core and let a heap of 2 m units on 4 m cells
pass far more than on fine cells (docs/theory.md, *Porous flow through the pile*; ``tests/swe/test_porous_layers.py``).
All layers feel the same free-surface gradient ``S`` (quasi-steady split):

* through layer ``k``, the superficial (Darcy) velocity ``V_k`` obeys Forchheimer's law
  ``S = A_k V_k + B_k V_k |V_k|``, the coefficients of the layer's porosity ``n`` and stone diameter ``d``
  by a flow law of :mod:`breachflow.swe.porous_laws` (Ergun's by default:
  ``A = 150 nu (1-n)^2 / (g n^3 d^2)``, ``B = 1.75 (1-n) / (g n^3 d)``);
* over the crest, Manning ``q_o = (h - H)^(5/3) S^(1/2) / n_M``.

The unit discharge of the column is ``Q(S) = sum_k t_k V_k(S) + q_o(S)``, ``t_k`` the wetted thickness of
layer ``k`` (the layers in parallel, as the flow through a stratified medium). The source term
``-g h S(q)`` of the momentum equation is applied implicitly after each time step (Lie splitting, like an
implicit friction): ``q' + dt g h S' = q*`` with ``q' = Q(S')`` — a monotone scalar equation solved by
bisection on ``S'`` — so the term only reduces ``|q|``, never reverses it, and a lake at rest (``q = 0``)
stays at rest. Mass is untouched by the term (conserved by the finite-volume fluxes); wet/dry is the
solver's. Limitation: the over-crest flow keeps the full column's momentum flux.

Pile storage: the pores of the pile hold ``n a`` of water per unit area where the depth is ``a`` in the
pile part; the model stores ``a`` there, i.e. it treats the pore water as free water and conserves
``sum h dx dy`` exactly (round-off; ``tests/swe/test_porous.py``), the volume the column would hold
without the solids. The remap puts a pile into a warm start without changing ``h``, so a pile neither
creates nor removes water in the model; the real water held in a pile cell is smaller by ``(1 - n) a dx dy``.
This changes how fast a transient fills or drains the pile (by up to ``1/n``), not a steady state — the
only thing the closure cycle uses.

A cell with no pile (``pile_height <= 0``) is left to the solver's Manning friction; in a pile cell that
friction is replaced by this law (the solver sets its Manning n to 0 there).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from ..errors import InputError
from .porous_laws import GRAVITY, NU_WATER, porous_law


def forchheimer_coefficients(porosity, diameter, law=None, nu=NU_WATER, g=GRAVITY):
    """``(A, B)`` (s/m, s²/m²) of the hydraulic gradient ``I = A V + B V|V|`` for porosity *n* and stone
    diameter *d* (m) by *law* (a name of :data:`~breachflow.swe.porous_laws.POROUS_LAWS` or an instance;
    None: the default); arrays broadcast."""
    return porous_law(law).coefficients(porosity, diameter, nu, g)


@dataclass
class PorousPile:
    """Per-cell pile of a domain (arrays ``(ny, nx)``): ``height`` above the bed (m, 0 = no pile),
    ``porosity`` (-, of the whole column), ``diameter`` (m, volume-weighted stone size), Forchheimer ``A``,
    ``B`` (of the whole column's porosity); ``law`` (the flow law's name, None: the default); ``layer_porosity``, ``layer_A``, ``layer_B``
    ``(ny, nx, K)`` of the column's ``K`` equal layers, bottom first (module docstring; None: one layer,
    the column's)."""

    height: np.ndarray
    porosity: np.ndarray
    diameter: np.ndarray
    A: np.ndarray
    B: np.ndarray
    law: str | None = None
    layer_porosity: np.ndarray | None = None
    layer_A: np.ndarray | None = None
    layer_B: np.ndarray | None = None

    def __post_init__(self):
        shape = np.shape(self.height)
        for name, column in (("layer_porosity", self.porosity), ("layer_A", self.A), ("layer_B", self.B)):
            value = getattr(self, name)
            if value is None:
                setattr(self, name, np.asarray(column, float)[..., None].copy())
            elif np.ndim(value) != len(shape) + 1 or np.shape(value)[:-1] != shape:
                raise InputError(f"PorousPile: {name} shape {np.shape(value)} is not the height's {shape} + (K,)")

    @classmethod
    def build(cls, height, porosity, diameter, law=None, min_porosity=0.2, max_porosity=0.95,
              layer_porosity=None):
        """Clip the porosity to ``[min_porosity, max_porosity]`` and compute ``A``, ``B`` where the pile is;
        *layer_porosity* ``(ny, nx, K)`` (bottom first) gives each layer its own (*porosity* is then their
        mean, the column's)."""
        h = np.asarray(height, float)
        where = h > 0
        d = np.where(where, np.asarray(diameter, float), 1.0)
        layers = None
        if layer_porosity is not None:
            ln = np.where(where[..., None], np.clip(np.asarray(layer_porosity, float), min_porosity, max_porosity), 1.0)
            la, lb = forchheimer_coefficients(np.where(where[..., None], ln, 0.5), d[..., None], law)
            layers = (ln, np.where(where[..., None], la, 0.0), np.where(where[..., None], lb, 0.0))
            porosity = ln.mean(axis=-1)
        n = np.where(where, np.clip(np.asarray(porosity, float), min_porosity, max_porosity), 1.0)
        A, B = forchheimer_coefficients(np.where(where, n, 0.5), d, law)
        pile = cls(height=np.where(where, h, 0.0), porosity=n, diameter=d, A=np.where(where, A, 0.0),
                   B=np.where(where, B, 0.0), law=law)
        if layers is not None:
            pile.layer_porosity, pile.layer_A, pile.layer_B = layers
        return pile

    @property
    def any(self) -> bool:
        return bool(np.any(self.height > 0))


@numba.njit(cache=True, nogil=True)
def _darcy_velocity(S, A, B):
    """Superficial velocity V >= 0 with ``A V + B V^2 = S``."""
    if S <= 0.0:
        return 0.0
    if B > 0.0:
        return 2.0 * S / (A + math.sqrt(A * A + 4.0 * B * S))
    if A > 0.0:
        return S / A
    return math.inf


@numba.njit(cache=True, nogil=True)
def column_discharge(S, h, H, A, B, n_free):
    """``(Q, q_seep)``: unit discharge of the column of depth *h* over a pile of height *H* with layers
    ``A[k], B[k]`` (bottom first) at gradient *S*, and its part through the pile."""
    K = A.shape[0]
    t = H / K
    qs = 0.0
    for k in range(K):
        bottom = k * t
        if h <= bottom:
            break
        qs += (min(h, H if k == K - 1 else bottom + t) - bottom) * _darcy_velocity(S, A[k], B[k])
    qo = 0.0
    if h > H:
        if n_free > 0.0:
            qo = (h - H) ** (5.0 / 3.0) * math.sqrt(S) / n_free
        else:
            qo = math.inf
    return qs + qo, qs


@numba.njit(cache=True, nogil=True)
def _solve_gradient(qstar, h, H, A, B, n_free, c):
    """``S >= 0`` with ``Q(S) + c S = qstar`` (bisection; ``c = dt g h``, 0 for the steady split)."""
    lo = 0.0
    if c > 0.0:
        hi = qstar / c
    else:
        hi = 1.0
        while column_discharge(hi, h, H, A, B, n_free)[0] < qstar and hi < 1e12:
            hi *= 4.0
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        if column_discharge(mid, h, H, A, B, n_free)[0] + c * mid > qstar:
            hi = mid
        else:
            lo = mid
        if hi - lo <= 1e-14 * hi:
            break
    return 0.5 * (lo + hi)


@numba.njit(cache=True, nogil=True)
def porous_resistance(h, hu, hv, pile, A, B, n_free, dt, g, h_dry):
    """Implicit Forchheimer + over-crest Manning resistance in the pile cells (*pile* the height and the
    others ``(ny, nx)``, the layers' *A*, *B* ``(ny, nx, K)``, e.g. the solver's padded ones); see the
    module docstring."""
    porous_resistance_box(h, hu, hv, pile, A, B, n_free, dt, g, h_dry, 0, h.shape[0], 0, h.shape[1])


@numba.njit(cache=True, nogil=True)
def porous_resistance_box(h, hu, hv, pile, A, B, n_free, dt, g, h_dry, j0, j1, i0, i1):
    """:func:`porous_resistance` on the cells ``[j0:j1, i0:i1]`` (the box holding the pile; the solver's
    time loop ``kernels.advance`` applies it after every step)."""
    for j in range(j0, j1):
        for i in range(i0, i1):
            p = pile[j, i]
            if p <= 0.0:
                continue
            hh = h[j, i]
            if hh <= h_dry:
                continue
            qx = hu[j, i]
            qy = hv[j, i]
            qm = math.sqrt(qx * qx + qy * qy)
            if qm == 0.0:
                continue
            if hh > p and n_free[j, i] <= 0.0:
                continue  # a free layer without friction carries any flow
            S = _solve_gradient(qm, hh, p, A[j, i], B[j, i], n_free[j, i], dt * g * hh)
            qn = max(qm - dt * g * hh * S, 0.0)
            f = qn / qm
            hu[j, i] = qx * f
            hv[j, i] = qy * f


@numba.njit(cache=True, nogil=True)
def seepage_unit_discharge(h, q, pile, A, B, n_free, out):
    """Per cell, the part of the unit discharge *q* (>= 0) through the pile in the steady split."""
    ny, nx = h.shape
    for j in range(ny):
        for i in range(nx):
            out[j, i] = 0.0
            p = pile[j, i]
            if p <= 0.0 or h[j, i] <= 0.0 or q[j, i] <= 0.0:
                continue
            if h[j, i] > p and n_free[j, i] <= 0.0:
                continue
            S = _solve_gradient(q[j, i], h[j, i], p, A[j, i], B[j, i], n_free[j, i], 0.0)
            out[j, i] = min(column_discharge(S, h[j, i], p, A[j, i], B[j, i], n_free[j, i])[1], q[j, i])


def seepage_field(depth, speed, pile: PorousPile, manning) -> np.ndarray:
    """Seepage unit discharge (m²/s) per cell from a (steady) snapshot's depth and speed."""
    h = np.ascontiguousarray(depth, float)
    q = np.ascontiguousarray(np.asarray(depth, float) * np.asarray(speed, float))
    out = np.zeros_like(h)
    nm = np.ascontiguousarray(np.broadcast_to(np.asarray(manning, float), h.shape))
    seepage_unit_discharge(h, q, np.ascontiguousarray(pile.height), np.ascontiguousarray(pile.layer_A),
                           np.ascontiguousarray(pile.layer_B), nm, out)
    return out


def forchheimer_dam_length(q, h_up, h_down, A, B):
    """Closed form of 1-D steady Dupuit–Forchheimer flow through a dam on a flat bed: the length ``L`` (m)
    over which unit discharge *q* (m²/s) drops the water depth from *h_up* to *h_down* (pile above the water).

    ``-dh/dx = A q/h + B q^2/h^2`` ⇒ ``dx = -h^2 dh / (A q h + B q^2)``; with ``c = B q / A``:
    ``L = [ (h1^2 - h2^2)/2 - c (h1 - h2) + c^2 ln((h1 + c)/(h2 + c)) ] / (A q)``; for ``A = 0``:
    ``L = (h1^3 - h2^3) / (3 B q^2)``.
    """
    h1, h2 = float(h_up), float(h_down)
    if A == 0.0:
        return (h1 ** 3 - h2 ** 3) / (3.0 * B * q * q)
    c = B * q / A
    return ((h1 ** 2 - h2 ** 2) / 2 - c * (h1 - h2) + c * c * math.log((h1 + c) / (h2 + c))) / (A * q)
