"""Sealing a rock dam: filter layers of finer grading on its upstream face, their stability and their effect.

A dumped rock dam leaks: the flow through its pores follows Forchheimer's law ``i = a V + b V|V|``
(:mod:`breachflow.swe.porous`, coefficients of Ergun 1952 or van Gent 1995 from the porosity and the
grain size). Finer material placed against its upstream face adds a layer of much higher resistance; the
leakage falls until it meets the closure criterion (:func:`breachflow.cycle.leakage.polder_leakage_check`).

Filter rules between two adjoining layers, the finer *base* behind (upstream of) the coarser *filter*
(Terzaghi; the Rock Manual §5.4.3.6 and USACE EM 1110-2-1901 state the geometric rules for granular filters):

* retention ``D15_filter / D85_base <= 5`` (:data:`RETENTION_LIMIT`): the base's grains cannot pass the
  filter's pores (above it the base washes out into the coarser layer);
* permeability ``D15_filter / D15_base >= 5`` (:data:`PERMEABILITY_LIMIT`): the coarser layer is much more
  permeable than the finer, so no head builds up between them.

For a seal the layers are, from the water: seal (finest) → … → core rock (coarsest). A design that breaks a
retention rule would wash out through the rock; :func:`check_filter` refuses it with an
:class:`~breachflow.errors.InputError` naming the layers and the ratio.

Seal model (first version): a layer of thickness ``t`` across the flow path through the dam, in series with
the rock. In 1-D steady flow the unit discharge ``q`` (m²/s) through a saturated column of height ``h`` and
layers of lengths ``L_k`` in series obeys ``H = sum_k L_k (a_k V + b_k V^2)``, ``V = q / h``; with the head
``H`` across the dam fixed, :func:`series_unit_discharge` solves it for ``q``. The seal of a dam whose
seepage the flow model gives as ``Q_rock`` lets through ``Q_rock * q_sealed / q_rock`` at the same head
(:func:`sealed_leakage`). Tonnage: ``volume * (1 - n) * rho_s``; time: tonnage / delivery capacity.
Limits: the head across the dam and the wetted height are taken as given (not re-solved with the seal in
the shallow-water model); the seal is a uniform layer over the wetted upstream face; internal erosion other
than the geometric rules (suffusion of gap-graded material) is not checked.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import InputError
from ..swe.porous import forchheimer_coefficients

#: Terzaghi's retention limit D15_filter / D85_base (a layer retains the finer one behind it below it)
RETENTION_LIMIT = 5.0
#: Terzaghi's permeability rule D15_filter / D15_base (the coarser layer drains the finer one above it)
PERMEABILITY_LIMIT = 5.0


@dataclass(frozen=True)
class Grading:
    """A granular layer's grain sizes (m): ``d15``, ``d50``, ``d85``; ``porosity``; ``density`` of the grains."""

    name: str
    d15: float
    d50: float
    d85: float
    porosity: float = 0.38
    density: float = 2650.0

    def __post_init__(self):
        if not (0 < self.d15 <= self.d50 <= self.d85):
            raise InputError(f"layer {self.name}: need 0 < D15 <= D50 <= D85, got {self.d15}, {self.d50}, {self.d85} m")
        if not 0 < self.porosity < 1:
            raise InputError(f"layer {self.name}: porosity must be in (0, 1), got {self.porosity}")

    @classmethod
    def from_rock(cls, rock) -> "Grading":
        """The nominal diameters D_n15/D_n50/D_n85 of a rock grading (:class:`~breachflow.materials.rock.GradedRock`)."""
        d = rock.diameter_at_fraction([0.15, 0.5, 0.85])
        return cls(rock.name, float(d[0]), float(d[1]), float(d[2]), rock.porosity, rock.density)

    def forchheimer(self, law: str | None = None) -> tuple[float, float]:
        """``(a, b)`` of ``i = a V + b V|V|`` for this layer (D50 as the grain size)."""
        a, b = forchheimer_coefficients(self.porosity, self.d50, law)
        return float(a), float(b)


def filter_ratios(base: Grading, filt: Grading) -> tuple[float, float]:
    """``(D15_filter / D85_base, D15_filter / D15_base)`` of a *filt* layer against the finer *base*."""
    return filt.d15 / base.d85, filt.d15 / base.d15


def check_filter(layers, retention_limit=RETENTION_LIMIT, permeability_limit=PERMEABILITY_LIMIT) -> list[dict]:
    """Check every interface of *layers* (finest first: seal, …, core rock) and return the ratios; raise
    :class:`~breachflow.errors.InputError` naming the layers and ratios when a layer would wash out through the
    next (retention) or would not drain (permeability)."""
    layers = list(layers)
    out, bad = [], []
    for base, filt in zip(layers[:-1], layers[1:]):
        ret, perm = filter_ratios(base, filt)
        row = {"base": base.name, "filter": filt.name, "retention": ret, "permeability": perm,
               "retains": ret <= retention_limit, "drains": perm >= permeability_limit}
        out.append(row)
        if not row["retains"]:
            bad.append(f"{base.name} would wash out through {filt.name}: D15_{filt.name}/D85_{base.name} = "
                       f"{ret:.3g} > {retention_limit:g}")
        if not row["drains"]:
            bad.append(f"{filt.name} does not drain {base.name}: D15_{filt.name}/D15_{base.name} = {perm:.3g} "
                       f"< {permeability_limit:g}")
    if bad:
        raise InputError("seal: filter rule broken — " + "; ".join(bad) +
                         " (add an intermediate layer of a grading in between)")
    return out


#: a seal list's last entry that asks for the filter layers up to the rock to be chosen by the rules
AUTO_FILTERS = "auto"


def _margin(base: Grading, filt: Grading, retention_limit: float, permeability_limit: float) -> float:
    """The smaller of ``limit / retention`` and ``permeability / limit`` at one interface (>= 1: both rules hold)."""
    ret, perm = filter_ratios(base, filt)
    return min(retention_limit / ret, perm / permeability_limit)


def bridge_filters(base: Grading, rock: Grading, candidates, retention_limit=RETENTION_LIMIT,
                   permeability_limit=PERMEABILITY_LIMIT, max_layers: int = 4) -> list:
    """The shortest run of *candidates* (:class:`Grading`, e.g. the EN 13383 gradings) between the finer *base*
    and the dam's *rock* such that every interface passes both filter rules (:func:`check_filter`): a
    breadth-first search over the candidates coarser than the layer before; among the shortest runs the one
    whose tightest interface has the largest margin (the smaller of
    ``limit / retention`` and ``permeability / limit``). ``[]`` when *base* lies on the rock
    directly. Raises :class:`~breachflow.errors.InputError` beginning "no seal designable" with the ratios of the
    nearest candidates against the rock when no run of at most *max_layers* layers exists."""
    cands = sorted({g.name: g for g in candidates}.values(), key=lambda g: (g.d15, g.d85))

    def ok(b, f):
        return _margin(b, f, retention_limit, permeability_limit) >= 1.0

    if ok(base, rock):
        return []
    frontier, best = [[]], None
    for _ in range(max_layers):
        nxt = []
        for run in frontier:
            last = run[-1] if run else base
            for g in cands:
                if g.d15 > last.d15 and g not in run and ok(last, g):
                    nxt.append(run + [g])
        done = [r for r in nxt if ok(r[-1], rock)]
        if done:
            def worst(r):
                chain = [base, *r, rock]
                return min(_margin(b, f, retention_limit, permeability_limit) for b, f in zip(chain[:-1], chain[1:]))
            best = max(done, key=worst)
            break
        frontier = nxt
        if not frontier:
            break
    if best is not None:
        return best
    need = rock.d15 / retention_limit
    near = []
    for g in cands:
        ret, perm = filter_ratios(g, rock)
        near.append((abs(math.log(g.d85 / need)) + abs(math.log(g.d15 / need)), g.name, ret, perm))
    rows = "; ".join(f"{name}: retention {ret:.3g}{' > ' if ret > retention_limit else ' <= '}{retention_limit:g}, "
                     f"permeability {perm:.3g}{' < ' if perm < permeability_limit else ' >= '}{permeability_limit:g}"
                     for _, name, ret, perm in sorted(near)[:3])
    onrock = [g.name for g in cands if ok(g, rock)]
    if onrock:
        rows += (f" ({', '.join(onrock)} would lie on the rock, but no run of the gradings from {base.name} reaches "
                 f"{'it' if len(onrock) == 1 else 'them'} within the rules)")
    raise InputError(
        f"no seal designable: no run of at most {max_layers} of the gradings {', '.join(g.name for g in cands)} "
        f"leads from {base.name} to {rock.name} (D15 {rock.d15:.3g} m) within the filter rules; the layer on the "
        f"rock needs D85 >= {rock.d15 / retention_limit:.3g} m (retention D15_rock/D85 <= {retention_limit:g}) and "
        f"D15 <= {rock.d15 / permeability_limit:.3g} m (permeability D15_rock/D15 >= {permeability_limit:g}); "
        f"nearest: {rows}")


def standard_filter_gradings() -> list:
    """The EN 13383 gradings of the materials registry as filter layers (:meth:`Grading.from_rock`: their
    D_n15, D_n50, D_n85 and porosity), the candidates of ``seal = [..., "auto"]``."""
    from . import _load_builtins, get_material
    from .rock import STANDARD_GRADINGS

    _load_builtins()
    return [Grading.from_rock(get_material(name)) for name in STANDARD_GRADINGS]


def series_unit_discharge(head: float, height: float, layers) -> float:
    """Unit discharge ``q`` (m²/s) through layers ``[(length m, a s/m, b s²/m²), ...]`` in series over a
    saturated height *height* (m) under a head *head* (m): the root of ``sum L_k (a_k V + b_k V^2) = H``,
    ``V = q / h`` (closed form of the quadratic)."""
    if head <= 0 or height <= 0:
        return 0.0
    A = sum(L * a for L, a, _ in layers)
    B = sum(L * b for L, _, b in layers)
    if B > 0:
        V = 2.0 * head / (A + math.sqrt(A * A + 4.0 * B * head))
    elif A > 0:
        V = head / A
    else:
        raise InputError("seal: the layers have no resistance (zero length)")
    return V * height


@dataclass
class SealDesign:
    """A seal of *grading* and *thickness* (m) on the upstream face of a dam of rock *rock* (both
    :class:`Grading`), with optional intermediate filter layers ``[(Grading, thickness m), ...]`` between them."""

    grading: Grading
    thickness: float
    rock: Grading
    filters: tuple = ()
    law: str | None = None
    retention_limit: float = RETENTION_LIMIT
    permeability_limit: float = PERMEABILITY_LIMIT

    def __post_init__(self):
        if not self.thickness > 0:
            raise InputError(f"seal: thickness must be > 0 m, got {self.thickness}")
        check_filter([self.grading, *[g for g, _ in self.filters], self.rock], self.retention_limit,
                     self.permeability_limit)

    def layers(self, rock_length: float):
        """The series ``[(length, a, b)]``: seal, filters, then the rock over *rock_length* (m)."""
        out = [(self.thickness, *self.grading.forchheimer(self.law))]
        out += [(t, *g.forchheimer(self.law)) for g, t in self.filters]
        rest = rock_length - self.thickness - sum(t for _, t in self.filters)
        if rest <= 0:
            raise InputError(f"seal: the seal and filters ({rock_length - rest:.3g} m) are thicker than the dam's "
                             f"flow path {rock_length:.3g} m")
        out.append((rest, *self.rock.forchheimer(self.law)))
        return out

    def reduction(self, head: float, height: float, rock_length: float) -> float:
        """``q_sealed / q_rock`` at the same head (1-D series model)."""
        q_rock = series_unit_discharge(head, height, [(rock_length, *self.rock.forchheimer(self.law))])
        if q_rock == 0.0:
            return 1.0
        return series_unit_discharge(head, height, self.layers(rock_length)) / q_rock

    def tonnage(self, face_area: float) -> dict:
        """Tonnes (t) of each layer over the wetted upstream *face_area* (m²): ``area t (1 - n) rho_s``."""
        out = {self.grading.name: face_area * self.thickness * (1 - self.grading.porosity) * self.grading.density / 1e3}
        for g, t in self.filters:
            out[g.name] = out.get(g.name, 0.0) + face_area * t * (1 - g.porosity) * g.density / 1e3
        return out


def sealed_leakage(q_rock_model: float, design: SealDesign, head: float, height: float, rock_length: float) -> float:
    """Leakage (m³/s) after sealing a dam through which the flow model gives *q_rock_model* (m³/s) at *head*."""
    return q_rock_model * design.reduction(head, height, rock_length)


def required_thickness(design: SealDesign, q_rock_model: float, target: float, head: float, height: float,
                       rock_length: float, max_fraction: float = 0.5) -> float:
    """The smallest seal thickness (m) that brings the leakage below *target* (m³/s), by bisection up to
    *max_fraction* of the flow path; ``inf`` when even that is not enough."""
    if q_rock_model <= target:
        return 0.0
    from dataclasses import replace

    def leak(t):
        return sealed_leakage(q_rock_model, replace(design, thickness=t), head, height, rock_length)

    hi = max_fraction * (rock_length - sum(t for _, t in design.filters))
    if hi <= 0 or leak(hi) > target:
        return math.inf
    lo = 0.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if mid > 0 and leak(mid) <= target:
            hi = mid
        else:
            lo = mid
    return hi


#: a sand seal and a gravel filter as a starting design (m): fine-to-medium sand, and a sandy gravel
DEFAULT_SEAL_GRADINGS = {
    "sand": Grading("sand", 0.15e-3, 0.3e-3, 0.6e-3, porosity=0.38),
    "gravel": Grading("gravel", 2.5e-3, 10e-3, 30e-3, porosity=0.33),
    "quarry_run": Grading("quarry_run", 0.04, 0.10, 0.20, porosity=0.35),
}

