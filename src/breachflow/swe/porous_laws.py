"""Flow laws of a porous pile, chosen by name: the Forchheimer coefficients of the hydraulic gradient.

Every law gives, per cell, ``(A, B)`` of ``I = A V + B V |V|`` (``I`` the hydraulic gradient, ``V`` the
superficial velocity) for the porosity ``n`` and the stone diameter ``d`` (docs/theory.md, *Porous flow
through the pile*). Built-in laws (registry ``breachflow.porous_laws``):

``ergun`` (default)
    Ergun (1952, *Chem. Eng. Prog.* 48:89-94) for packed beds, ``A = 150 nu (1-n)^2 / (g n^3 d^2)``,
    ``B = 1.75 (1-n) / (g n^3 d)``.
``van_gent``
    The same form with van Gent's coefficients for stationary flow through rock, 1000 and 1.1 (van Gent
    1995, *Wave interaction with permeable coastal structures*, PhD TU Delft; both as compiled in
    Burcharth & Andersen 1995, *Coastal Eng.* 24:233-257).
``ergun_dilute``
    Ergun for a packed pile, and for a sparse one the drag of the stones themselves: the smaller of
    Ergun's ``B`` and the voidage law of a suspension of spheres at high Reynolds number,
    ``B = 3/4 C_D (1-n) n^(-2 m) / (g d)`` — the drag of ``(1-n) / (pi d^3 / 6)`` spheres per volume, each
    ``C_D rho (pi d^2 / 4) V^2 / 2`` at the superficial velocity raised by the hindrance ``n^(-2 m)``,
    where ``m = 2.39`` is Richardson & Zaki's exponent for Newton-regime spheres (1954, *Trans. Inst.
    Chem. Eng.* 32:35-53: a suspension at rest in an upflow ``V = U_t n^m``) and ``C_D = 0.44`` a lone
    sphere's drag in that regime. At ``n -> 1`` it is a lone stone's drag; the two laws meet at
    ``n = (3 C_D / 7)^(1 / (2 m - 3)) = 0.392``, a packed pile's porosity, so a dense pile keeps Ergun.
    Di Felice's voidage function (1994, *Int. J. Multiphase Flow* 20:153-159; exponent 3.7 on the
    drag, 4.7 on the gradient) is the same law with a smaller exponent. ``A`` is Ergun's (negligible for
    stones of a metre: the particle Reynolds number ``V d / nu`` is 1e5 and more). On cells coarser than
    a stone a lone stone is a column of high porosity: with Ergun's ``B`` it resists about ``1.75 / (3/4
    C_D) = 5.3`` times its own drag, and a scatter of units passed less the coarser the cells.

A plug-in law is a class whose instances have :meth:`PorousLaw.coefficients`, declared in the entry
point group ``breachflow.porous_laws``.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from ..errors import InputError
from ..registry import Registry

NU_WATER = 1.0e-6
GRAVITY = 9.81

#: The registry of porous-pile flow laws (``POROUS_LAWS.create(name)`` an instance).
POROUS_LAWS: Registry = Registry("porous flow law", "breachflow.porous_laws", default="ergun")


class PorousLaw(Protocol):
    """A porous flow law: the coefficients of ``I = A V + B V |V|``."""

    def coefficients(self, porosity: np.ndarray, diameter: np.ndarray, nu: float = NU_WATER,
                     g: float = GRAVITY) -> tuple[np.ndarray, np.ndarray]:
        """``(A, B)`` (s/m, s²/m²) for porosity in (0, 1) and diameter > 0 (m), arrays broadcast."""


def _checked(porosity, diameter):
    n = np.asarray(porosity, float)
    d = np.asarray(diameter, float)
    if np.any((n <= 0) | (n >= 1)) or np.any(d <= 0):
        raise InputError("porosity must be in (0, 1) and the stone diameter > 0")
    return n, d


@POROUS_LAWS.register("ergun")
@dataclass(frozen=True)
class ForchheimerLaw:
    """``A = alpha nu (1-n)^2 / (g n^3 d^2)``, ``B = beta (1-n) / (g n^3 d)``; Ergun's 150 and 1.75 by default."""

    alpha: float = 150.0
    beta: float = 1.75

    def coefficients(self, porosity, diameter, nu=NU_WATER, g=GRAVITY):
        n, d = _checked(porosity, diameter)
        return (self.alpha * nu * (1 - n) ** 2 / (g * n ** 3 * d ** 2),
                self.beta * (1 - n) / (g * n ** 3 * d))


@POROUS_LAWS.register("van_gent")
@dataclass(frozen=True)
class VanGentLaw(ForchheimerLaw):
    """:class:`ForchheimerLaw` with van Gent's (1995) 1000 and 1.1 for stationary flow through rock."""

    alpha: float = 1000.0
    beta: float = 1.1


@POROUS_LAWS.register("ergun_dilute")
@dataclass(frozen=True)
class ErgunDiluteLaw:
    """Ergun, and the drag of the stones in a sparse pile: ``B = min(B_Ergun, 3/4 C_D (1-n) n^(-2m) / (g d))``
    (module docstring; Richardson & Zaki 1954, ``m = 2.39``; ``C_D = 0.44``)."""

    drag_coefficient: float = 0.44
    exponent: float = 2.39
    packed: ForchheimerLaw = ForchheimerLaw()

    def coefficients(self, porosity, diameter, nu=NU_WATER, g=GRAVITY):
        n, d = _checked(porosity, diameter)
        A, B = self.packed.coefficients(n, d, nu, g)
        sparse = 0.75 * self.drag_coefficient * (1 - n) * n ** (-2.0 * self.exponent) / (g * d)
        return A, np.minimum(B, sparse)

    def crossover_porosity(self) -> float:
        """The porosity where the two laws meet: ``(3/4 C_D / beta)^(1 / (2 m - 3))``."""
        return (0.75 * self.drag_coefficient / self.packed.beta) ** (1.0 / (2.0 * self.exponent - 3.0))


def porous_law(law=None) -> PorousLaw:
    """The law called *law* (None: the default, ``ergun``), or *law* itself when it is an instance."""
    return POROUS_LAWS.create(POROUS_LAWS.default if law is None else law)
