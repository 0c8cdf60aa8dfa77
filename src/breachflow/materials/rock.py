"""Graded quarry rock by the standard classes of EN 13383-1 (armourstone), and the shape drag of angular units.

A standard grading is named by its nominal lower and upper limits NLL–NUL (kg) and bounded by the extreme
limits ELL, EUL; the standard requires, by mass, less than 5 % lighter than ELL, less than 10 % lighter than
NLL, more than 70 % lighter than NUL and more than 97 % lighter than EUL, and for category A the mean unit
mass ``M_em`` (total mass / number of units) within a given range (EN 13383-1:2002 Tables 4 and 5; CIRIA,
CUR, CETMEF 2007, *The Rock Manual*, §3.4.3, Tables 3.5 and 3.6).

Grading curve. The Rock Manual describes the mass distribution of armourstone by a Rosin–Rammler curve,
``y(M) = 1 - exp(ln(0.5) (M / M50)^n_RRM)`` (mass fraction lighter than ``M``; Rock Manual Eq. 3.4). Here the
curve of a class is cut at ELL and EUL (no unit outside the extreme limits) and its two parameters are chosen
so that the cut curve passes inside the nominal limits with a margin, ``y(NLL) = 0.08`` and ``y(NUL) = 0.75``
(:data:`CURVE_FRACTIONS`); the mean unit mass ``M_em`` then falls inside the standard's range for every class
(checked in the test suite). Unit masses are drawn *by number*: for a
Rosin–Rammler mass distribution with exponent ``n`` the number of units follows ``X = (M/lambda)^n ~
Gamma(1 - 1/n)`` (the mass density divided by ``M``), ``lambda = M50 / ln(2)^(1/n)``. The test suite checks
every class against the standard's limits and ``M_em`` ranges.

Shape drag. Quarried rock is angular and roughly isometric; its drag has no drag crisis (the sharp edges fix
the separation) and a Newton-regime coefficient above a sphere's 0.44. Ganser (1993, *Powder Technol.* 77,
143–152; reviewed by Loth 2008, *Powder Technol.* 182, 342–353) correlates it with the sphericity ``psi``
(surface of the equal-volume sphere / the particle's surface): ``C_D = 0.4305 K2`` with
``K2 = 10^(1.8148 (-log10 psi)^0.5743)``; a cube (``psi`` = 0.806) gets 1.25, quarried rock with ``psi`` about
0.8 the same. :func:`ganser_newton_cd` gives it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from . import MATERIALS

#: EN 13383-1 heavy (HM) and light (LM) gradings: name → (ELL, NLL, NUL, EUL, M_em low, M_em high), kg
STANDARD_GRADINGS = {
    "HMA_300_1000": (200.0, 300.0, 1000.0, 1500.0, 540.0, 690.0),
    "HMA_1000_3000": (650.0, 1000.0, 3000.0, 4500.0, 1700.0, 2100.0),
    "HMA_3000_6000": (2000.0, 3000.0, 6000.0, 9000.0, 4200.0, 4800.0),
    "HMA_6000_10000": (4000.0, 6000.0, 10000.0, 15000.0, 7500.0, 8500.0),
    "HMA_10000_15000": (6500.0, 10000.0, 15000.0, 22500.0, 12000.0, 13000.0),
    "LMA_5_40": (1.5, 5.0, 40.0, 60.0, 10.0, 20.0),
    "LMA_10_60": (2.0, 10.0, 60.0, 120.0, 20.0, 35.0),
    "LMA_40_200": (15.0, 40.0, 200.0, 300.0, 80.0, 120.0),
    "LMA_60_300": (20.0, 60.0, 300.0, 450.0, 120.0, 190.0),
}

#: mass fractions lighter than ELL, NLL, NUL, EUL the standard allows: (< 0.05, < 0.10, > 0.70, > 0.97)
LIMIT_FRACTIONS = (0.05, 0.10, 0.70, 0.97)

#: mass fractions lighter than NLL and NUL the grading curve of a class passes through (cut curve)
CURVE_FRACTIONS = (0.08, 0.75)

#: sphericity of quarried rock used for its drag (Ganser's correlation); a cube has 0.806
ROCK_SPHERICITY = 0.8
#: rolling resistance of an angular rock on a bed of rock (volume-equivalent sphere), calibrated against
#: Izbash's critical velocity (documentation page *Materials and the seal*)
ROCK_ROLLING_FRICTION = 1.2
#: Coulomb friction rock on rock (tan 31°; the closure run's default)
ROCK_FRICTION = 0.6
#: porosity of a dumped layer of a standard grading (Rock Manual §3.5: 0.35–0.40 for standard gradings)
ROCK_POROSITY = 0.38


def ganser_newton_cd(sphericity: float) -> float:
    """Newton-regime drag coefficient of an isometric non-spherical particle of *sphericity* (Ganser 1993):
    ``0.4305 * 10^(1.8148 (-log10 psi)^0.5743)``; 0.43 for a sphere."""
    psi = float(sphericity)
    if not 0.0 < psi <= 1.0:
        raise InputError(f"sphericity must be in (0, 1], got {sphericity!r}")
    k2 = 10.0 ** (1.8148 * (-math.log10(psi)) ** 0.5743) if psi < 1.0 else 1.0
    return 0.4305 * k2


def rosin_rammler_through(m_a: float, y_a: float, m_b: float, y_b: float) -> tuple[float, float]:
    """``(M50, n)`` of the Rosin–Rammler curve ``y = 1 - exp(ln 0.5 (M/M50)^n)`` through ``(m_a, y_a)`` and
    ``(m_b, y_b)`` (masses in kg, mass fractions lighter)."""
    la, lb = math.log(1.0 - y_a), math.log(1.0 - y_b)
    n = math.log(lb / la) / math.log(m_b / m_a)
    m50 = m_a * (math.log(0.5) / la) ** (1.0 / n)
    return m50, n


@dataclass
class GradedRock:
    """Quarry rock of a grading ``nll``–``nul`` (kg) cut at ``ell``/``eul``; a Rosin–Rammler curve through
    ``y(NLL) = 0.08``, ``y(NUL) = 0.75`` after the cut (module docstring). Parameters are plain fields a force model reads."""

    name: str
    ell: float
    nll: float
    nul: float
    eul: float
    mem_range: tuple = (math.nan, math.nan)
    density: float = 2650.0
    sphericity: float = ROCK_SPHERICITY
    drag_coefficient: float | None = None
    lift_coefficient: float | None = None
    added_mass_coefficient: float | None = None
    friction: float = ROCK_FRICTION
    rolling_friction: float = ROCK_ROLLING_FRICTION
    porosity: float = ROCK_POROSITY
    shape: str = "angular"
    m50: float = field(init=False)
    n_rrm: float = field(init=False)
    _scale: float = field(init=False, repr=False)

    def __post_init__(self):
        if not (0 < self.ell <= self.nll < self.nul <= self.eul):
            raise InputError(f"rock grading {self.name}: need 0 < ELL <= NLL < NUL <= EUL, got "
                             f"{self.ell}, {self.nll}, {self.nul}, {self.eul} kg")
        if not self.density > 1000.0:
            raise InputError(f"rock grading {self.name}: density must exceed water's, got {self.density}")
        self._scale, self.n_rrm = _fit_cut_curve(self.ell, self.nll, self.nul, self.eul, *CURVE_FRACTIONS)
        self.m50 = float(self.mass_at_fraction(0.5))
        if self.n_rrm <= 1.0:
            raise InputError(f"rock grading {self.name}: too wide (Rosin–Rammler exponent {self.n_rrm:.3g} <= 1)")
        if self.drag_coefficient is None:
            self.drag_coefficient = ganser_newton_cd(self.sphericity)

    @property
    def scale(self) -> float:
        """``lambda`` of the uncut curve ``y = 1 - exp(-(M/lambda)^n)`` (kg)."""
        return self._scale

    def mean_unit_mass(self) -> float:
        """``M_em`` (kg): the mean mass by number of the cut grading (incomplete gamma functions)."""
        from scipy.special import gamma, gammainc

        n, lam = self.n_rrm, self.scale
        a = 1.0 - 1.0 / n
        xl, xh = (self.ell / lam) ** n, (self.eul / lam) ** n
        return float(lam * (gammainc(1.0, xh) - gammainc(1.0, xl)) / (gammainc(a, xh) - gammainc(a, xl)) / gamma(a))

    def mass_fraction_lighter(self, m) -> np.ndarray:
        """The grading curve cut at ELL and EUL: mass fraction lighter than *m* (kg)."""
        def y(x):
            return 1.0 - np.exp(-(np.asarray(x, float) / self.scale) ** self.n_rrm)
        lo, hi = y(self.ell), y(self.eul)
        return np.clip((y(m) - lo) / (hi - lo), 0.0, 1.0)

    def mass_at_fraction(self, y) -> np.ndarray:
        """Inverse of :meth:`mass_fraction_lighter`: ``M_y`` (kg), e.g. ``y = 0.5`` the median mass by mass."""
        yy = np.asarray(y, float)
        lo = 1.0 - math.exp(-(self.ell / self.scale) ** self.n_rrm)
        hi = 1.0 - math.exp(-(self.eul / self.scale) ** self.n_rrm)
        return self.scale * (-np.log(1.0 - (lo + yy * (hi - lo)))) ** (1.0 / self.n_rrm)

    def diameter_at_fraction(self, y) -> np.ndarray:
        """Nominal diameter ``D_n,y = (M_y/rho)^(1/3)`` (m) at mass fraction *y* (``D_n50`` at 0.5)."""
        return np.cbrt(self.mass_at_fraction(y) / self.density)

    @property
    def dn50(self) -> float:
        """Median nominal diameter ``D_n50 = (M50/rho_s)^(1/3)`` (m) of the cut curve."""
        return float(self.diameter_at_fraction(0.5))

    def sample_masses(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """*n* unit masses (kg): by number, ``(M/lambda)^n ~ Gamma(1 - 1/n)``, redrawn outside ELL–EUL."""
        out = np.empty(0)
        a = 1.0 - 1.0 / self.n_rrm
        while out.size < n:
            m = self.scale * rng.gamma(a, 1.0, size=max(2 * (n - out.size), 8)) ** (1.0 / self.n_rrm)
            out = np.concatenate([out, m[(m >= self.ell) & (m <= self.eul)]])
        return out[:n]


def _fit_cut_curve(ell, nll, nul, eul, y_nll, y_nul) -> tuple[float, float]:
    """``(lambda, n)`` of ``1 - exp(-(M/lambda)^n)`` whose cut at ELL–EUL passes through ``(NLL, y_nll)`` and
    ``(NUL, y_nul)`` (scipy ``fsolve`` from the uncut curve through the same points)."""
    from scipy.optimize import fsolve

    m50, n0 = rosin_rammler_through(nll, y_nll, nul, y_nul)

    def resid(p):
        lam, n = math.exp(p[0]), math.exp(p[1])
        Y = lambda m: -math.expm1(-(m / lam) ** n)  # noqa: E731
        lo, hi = Y(ell), Y(eul)
        return [(Y(nll) - lo) / (hi - lo) - y_nll, (Y(nul) - lo) / (hi - lo) - y_nul]

    p, _, ok, msg = fsolve(resid, [math.log(m50 / math.log(2.0) ** (1.0 / n0)), math.log(n0)], full_output=True)
    if ok != 1 or max(abs(v) for v in resid(p)) > 1e-8:
        raise InputError(f"rock grading {nll:g}-{nul:g} kg: no grading curve through the limits ({msg})")
    return float(math.exp(p[0])), float(math.exp(p[1]))


def _standard(name):
    ell, nll, nul, eul, lo, hi = STANDARD_GRADINGS[name]

    def make(**params):
        return GradedRock(name=name, ell=ell, nll=nll, nul=nul, eul=eul, mem_range=(lo, hi), **params)

    make.__doc__ = f"EN 13383-1 grading {name.replace('_', ' ', 1).replace('_', '-')} kg (ELL {ell:g}, EUL {eul:g} kg)."
    return make


for _name in STANDARD_GRADINGS:  # module-level factories: the entry points in pyproject.toml name them
    globals()[_name] = MATERIALS.register(_name, _standard(_name))


@MATERIALS.register("rock")
def custom_rock(nll, nul, ell=None, eul=None, **params) -> GradedRock:
    """A non-standard grading ``nll``–``nul`` kg (ELL default 0.7 NLL, EUL 1.5 NUL, as the heavy gradings)."""
    nll, nul = float(nll), float(nul)
    return GradedRock(name=f"rock_{nll:g}_{nul:g}", ell=0.7 * nll if ell is None else float(ell), nll=nll, nul=nul,
                      eul=1.5 * nul if eul is None else float(eul), **params)
