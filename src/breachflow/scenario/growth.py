"""Empirical breach growth and maximum breach length (docs/theory.md, *Breach growth*; report §2.6, Tables 2.8–2.9, Fig 2.15).

Each equation is a plug-in class in a named registry with one method, ``length``, taking SI inputs
(development time ``t_D`` in s, heights in m, levee area in m²) and returning the breach length B in m.
The report's formulas are in hours and metres; the classes convert. Third-party equations register
through the entry-point groups ``breachflow.breach_growth`` and ``breachflow.breach_max_length``.

Growth (B vs t_D, t_D in hours)::

    =====  ==========================================  ===============================================
    2.2    MacDonald & Langridge-Monopolis 1984         ``B = 63075 t_D^2.747 / A_L``
    2.3    Pugh 1985 (fuse-plug embankments)            ``B = K (4.02 h_L + 45.7) t_D``,
                                                        ``K = 0.8039 (h_W/h_L)^2 + 0.003 (h_W/h_L)``
    2.4    USBR 1988                                    ``B = 91 t_D``
    2.5    von Thun & Gillette 1990, erosion-resistant  ``B = 4 h_W t_D``
    2.6    von Thun & Gillette 1990, erodible           ``B = (4 h_W + 61) t_D``
    2.7    Verheij 2002, compacted clay levees          ``B = 13.4 t_D^0.51``
    2.8    Verheij 2002, compacted sand levees          ``B = 37.2 t_D^0.51``
    =====  ==========================================  ===============================================

Maximum length: (2.9) ``B = 10 h_W``; (2.10) ``B = 2.5 h_W + 54.9``; (2.11) ``B = 5.19 e^{0.75 h_W}``
(Nagy 2006; the report's "e = 2.7812" is a typo for 2.71828).
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import xarray as xr

from ..errors import BreachflowWarning, InputError
from ..registry import Registry
from .geometry import LeveeGeometry
from .quantities import si_input

HOUR = 3600.0

growth_equations: Registry = Registry("breach growth equation", "breachflow.breach_growth")
max_length_equations: Registry = Registry("maximum breach length equation", "breachflow.breach_max_length")


@dataclass(frozen=True)
class GrowthInputs:
    """SI inputs an equation may need: water height h_W, levee height h_L, levee area A_L, levee base width."""

    surge_height: object = None
    levee_height: object = None
    levee_area: object = None
    levee_base_width: object = None

    def need(self, name: str, equation: str):
        value = getattr(self, name)
        if value is None:
            raise InputError(f"breach growth equation {equation!r} needs {name.replace('_', ' ')} "
                             f"({'levee=' if name.startswith('levee') else 'surge_height='})")
        return value


class GrowthEquation:
    """Base of the growth plug-ins: metadata plus ``length(t_D_seconds, inputs) -> metres``."""

    name = ""
    title = ""
    equation = ""
    source = ""
    applies_to = ""
    formula = ""
    needs: tuple[str, ...] = ()

    def length(self, development_time, inputs: GrowthInputs):  # pragma: no cover - abstract
        raise NotImplementedError

    @classmethod
    def describe(cls) -> dict:
        return {"name": cls.name, "equation": cls.equation, "source": cls.source,
                "applies_to": cls.applies_to, "formula": cls.formula, "needs": list(cls.needs)}


def _growth(cls):
    growth_equations.register(cls.name, cls)
    return cls


def _max_length(cls):
    max_length_equations.register(cls.name, cls)
    return cls


@_growth
class MacDonaldLangridgeMonopolis(GrowthEquation):
    name = "macdonald_langridge_monopolis"
    title = "MacDonald & Langridge-Monopolis"
    equation = "2.2"
    source = "after MacDonald & Langridge-Monopolis 1984"
    applies_to = "earthen embankment dams, compacted soils"
    formula = "B = 63075 t_D^2.747 / A_L  (eroded volume (t_D/0.0179)^(1/0.364) m^3 over the levee section)"
    needs = ("levee_area",)

    def length(self, t, p):
        return 63075.0 * (t / HOUR) ** 2.747 / p.need("levee_area", self.name)


@_growth
class Pugh(GrowthEquation):
    name = "pugh"
    title = "Pugh"
    equation = "2.3"
    source = "after Pugh 1985"
    applies_to = "fuse-plug embankments, h_W/W_b >= 0.12"
    formula = ("B = K (4.02 h_L + 45.7) t_D, K = 0.8039 (h_W/h_L)^2 + 0.003 (h_W/h_L) "
               "(operator of the 2nd term unreadable in the source; '+' assumed)")
    needs = ("surge_height", "levee_height")

    def length(self, t, p):
        h_w, h_l = p.need("surge_height", self.name), p.need("levee_height", self.name)
        ratio = h_w / h_l
        if p.levee_base_width is not None and np.any(np.asarray(h_w / p.levee_base_width) < 0.12):
            warnings.warn("pugh (eq 2.3) applies to h_W/W_b >= 0.12; this levee is outside that range",
                          BreachflowWarning, stacklevel=3)
        k = 0.8039 * ratio ** 2 + 0.003 * ratio
        return k * (4.02 * h_l + 45.7) * (t / HOUR)


@_growth
class USBR(GrowthEquation):
    name = "usbr"
    title = "USBR"
    equation = "2.4"
    source = "USBR 1988"
    applies_to = "earthen embankment dams"
    formula = "B = 91 t_D"

    def length(self, t, p):
        return 91.0 * (t / HOUR)


@_growth
class VonThunGilletteResistant(GrowthEquation):
    name = "von_thun_gillette_resistant"
    title = "von Thun & Gillette, resistant"
    equation = "2.5"
    source = "von Thun & Gillette 1990"
    applies_to = "erosion-resistant soils"
    formula = "B = 4 h_W t_D"
    needs = ("surge_height",)

    def length(self, t, p):
        return 4.0 * p.need("surge_height", self.name) * (t / HOUR)


@_growth
class VonThunGilletteErodible(GrowthEquation):
    name = "von_thun_gillette_erodible"
    title = "von Thun & Gillette, erodible"
    equation = "2.6"
    source = "von Thun & Gillette 1990"
    applies_to = "erodible soils"
    formula = "B = (4 h_W + 61) t_D"
    needs = ("surge_height",)

    def length(self, t, p):
        return (4.0 * p.need("surge_height", self.name) + 61.0) * (t / HOUR)


@_growth
class VerheijClay(GrowthEquation):
    name = "verheij_clay"
    title = "Verheij, clay"
    equation = "2.7"
    source = "after Verheij 2002"
    applies_to = "compacted clay levees"
    formula = "B = 13.4 t_D^0.51"

    def length(self, t, p):
        return 13.4 * (t / HOUR) ** 0.51


@_growth
class VerheijSand(GrowthEquation):
    name = "verheij_sand"
    title = "Verheij, sand"
    equation = "2.8"
    source = "after Verheij 2002"
    applies_to = "compacted sand levees"
    formula = "B = 37.2 t_D^0.51"

    def length(self, t, p):
        return 37.2 * (t / HOUR) ** 0.51


@_growth
class ResioResistant(GrowthEquation):
    name = "resio_resistant"
    title = "Resio et al. 9 m/h"
    equation = "rate"
    source = "Resio et al. 2009 (observed lateral growth rate)"
    applies_to = "erosion-resistant soils, 9 m/h"
    formula = "B = 9 m/h × t_D"

    def length(self, t, p):
        return 9.0 * (t / HOUR)


@_growth
class ResioErodible(GrowthEquation):
    name = "resio_erodible"
    title = "Resio et al. 60 m/h"
    equation = "rate"
    source = "Resio et al. 2009 (observed lateral growth rate)"
    applies_to = "erodible soils, 60 m/h"
    formula = "B = 60 m/h × t_D"

    def length(self, t, p):
        return 60.0 * (t / HOUR)


class MaxLengthEquation:
    """Base of the maximum-length plug-ins: ``length(surge_height_m) -> metres``."""

    name = title = equation = source = applies_to = formula = ""

    def length(self, surge_height):  # pragma: no cover - abstract
        raise NotImplementedError

    @classmethod
    def describe(cls) -> dict:
        return {"name": cls.name, "equation": cls.equation, "source": cls.source,
                "applies_to": cls.applies_to, "formula": cls.formula}


@_max_length
class MaxMacDonaldLangridgeMonopolis(MaxLengthEquation):
    name = "macdonald_langridge_monopolis"
    title = "MacDonald & Langridge-Monopolis"
    equation = "2.9"
    source = "after MacDonald & Langridge-Monopolis 1984"
    applies_to = "earthen embankment dams"
    formula = "B = 10 h_W"

    def length(self, h):
        return 10.0 * h


@_max_length
class MaxVonThunGillette(MaxLengthEquation):
    name = "von_thun_gillette"
    title = "von Thun & Gillette"
    equation = "2.10"
    source = "von Thun & Gillette 1990"
    applies_to = "earthen embankment dams"
    formula = "B = 2.5 h_W + 54.9"

    def length(self, h):
        return 2.5 * h + 54.9


@_max_length
class MaxNagy(MaxLengthEquation):
    name = "nagy"
    title = "Nagy"
    equation = "2.11"
    source = "Nagy 2006 (142 failures of Tisza River levees)"
    applies_to = "compacted clay levees"
    formula = "B = 5.19 exp(0.75 h_W)"

    def length(self, h):
        return 5.19 * np.exp(0.75 * h)


def _resolve(registry: Registry, name: str):
    """Look up by registry name or equation number (``"2.7"``)."""
    key = str(name).strip().lower()
    if key.startswith("eq"):
        key = key.lstrip("eq. ").strip()
    for item in registry.available():
        if registry.get(item).equation == key:
            return registry.get(item)
    return registry.get(key)


def _equation_order(registry: Registry, name: str):
    number = registry.get(name).equation
    parts = number.split(".")
    return (0, tuple(int(x) for x in parts), name) if all(x.isdigit() for x in parts) else (1, (), name)


def _names(registry: Registry, equation) -> list[str]:
    if equation is None or (isinstance(equation, str) and equation.lower() == "all"):
        return sorted(registry.available(), key=lambda n: _equation_order(registry, n))
    items = [equation] if isinstance(equation, str) else list(equation)
    return [_resolve(registry, e).name for e in items]


def _inputs(surge_height, levee) -> GrowthInputs:
    if levee is not None and not isinstance(levee, LeveeGeometry):
        levee = LeveeGeometry.from_input(**dict(levee))
    h = None if surge_height is None else si_input(surge_height, name="surge_height", kind="length", positive=True)
    if h is None and levee is not None:
        h = levee.height  # water at the levee crest, as in Fig 2.15
    return GrowthInputs(surge_height=h, levee_height=None if levee is None else levee.height,
                        levee_area=None if levee is None else levee.area,
                        levee_base_width=None if levee is None else levee.base_width)


def max_breach_length(equation="all", surge_height=None) -> xr.DataArray:
    """Maximum breach length (m) by equations 2.9–2.11 (names or numbers); dim ``equation`` when several."""
    h = si_input(surge_height, name="surge_height", kind="length", positive=True)
    names = _names(max_length_equations, equation)
    parts = []
    for n in names:
        cls = max_length_equations.get(n)
        parts.append(xr.DataArray(cls().length(h)) if not isinstance(h, xr.DataArray) else cls().length(h))
    out = xr.concat(parts, dim=xr.DataArray(names, dims="equation", name="equation"), coords="minimal") \
        if len(names) > 1 or not isinstance(equation, str) or equation == "all" else parts[0]
    out = out.rename("max_breach_length")
    out.attrs = {"units": "m", "long_name": "maximum breach length (report Table 2.9)"}
    if "equation" in out.dims:
        out["equation"].attrs = {"long_name": "maximum breach length equation",
                                 "equation_numbers": ", ".join(max_length_equations.get(n).equation for n in names)}
    else:
        cls = max_length_equations.get(names[0])
        out.attrs.update(equation=cls.equation, source=cls.source, formula=cls.formula)
    return out


def breach_length(equation="all", development_time=None, *, surge_height=None, levee=None,
                  max_length=None) -> xr.DataArray:
    """Breach length B (m) vs development time t_D by growth equations 2.2–2.8 (+ Resio rates).

    ``development_time``: times with units (list, DataArray; default 0–8 h); a list becomes the
    ``development_time`` dimension (stored in s). ``levee``: a :class:`~breachflow.scenario.geometry.LeveeGeometry` (or a dict of its
    fields with units) for equations needing h_L or A_L; ``surge_height`` defaults to the levee height.
    ``max_length``: a length with units, or the name/number of a maximum-length equation (2.9–2.11),
    caps every curve (``uncapped_breach_length`` is kept as an attribute-documented variable).
    Returns a DataArray with dims ``(equation, development_time, ...)``.
    """
    if development_time is None:
        development_time = xr.DataArray(np.linspace(0.0, 8.0, 81), dims="development_time", attrs={"units": "h"})
    t = si_input(development_time, name="development_time", kind="time", nonnegative=True)
    if not isinstance(t, xr.DataArray):
        t = xr.DataArray(t)
    elif "development_time" in t.dims:
        t = t.assign_coords(development_time=("development_time", np.asarray(t.values),
                                              {"units": "s", "long_name": "breach development time t_D"}))
    p = _inputs(surge_height, levee)
    names = _names(growth_equations, equation)
    curves = [growth_equations.create(n).length(t, p) for n in names]
    curves = [c if isinstance(c, xr.DataArray) else xr.DataArray(c) for c in curves]
    single = isinstance(equation, str) and equation != "all"
    out = curves[0] if single else xr.concat(
        curves, dim=xr.DataArray(names, dims="equation", name="equation"), coords="minimal", join="outer")
    out = out.rename("breach_length")
    attrs = {"units": "m", "long_name": "breach length along the levee centreline (B)"}
    if single:
        cls = growth_equations.get(names[0])
        attrs.update(equation=cls.equation, source=cls.source, formula=cls.formula, applies_to=cls.applies_to)
    if max_length is not None:
        cap = _cap(max_length, p)
        out = np.minimum(out, cap)
        attrs["capped_by"] = cap.attrs["formula"] if isinstance(cap, xr.DataArray) and "formula" in cap.attrs else str(max_length)
        attrs["max_length_m"] = float(np.max(np.asarray(cap)))
    out.attrs = attrs
    if "equation" in out.dims:
        out["equation"].attrs = {"long_name": "breach growth equation (report Table 2.8)"}
    return out


def _cap(max_length, p: GrowthInputs):
    """A cap from a length with units, or from a maximum-length equation (name or number) and h_W."""
    if isinstance(max_length, str):
        try:
            cls = _resolve(max_length_equations, max_length)
        except InputError:
            cls = None
        if cls is not None:
            h = p.need("surge_height", "maximum length")
            cap = cls().length(h)
            cap = cap if isinstance(cap, xr.DataArray) else xr.DataArray(cap)
            cap.attrs["formula"] = f"eq {cls.equation} ({cls.source}): {cls.formula}"
            return cap
    return si_input(max_length, name="max_length", kind="length", positive=True)


def growth_rate_summary(equation, surge_height=None, levee=None, hours=(1.0, 2.0, 4.0, 8.0)) -> dict:
    """Breach length at a few development times, as plain floats (m), for tables."""
    da = breach_length(equation, [f"{h} h" for h in hours], surge_height=surge_height, levee=levee)
    return {h: float(v) for h, v in zip(hours, np.asarray(da.values).ravel())}


__all__ = ["growth_equations", "max_length_equations", "breach_length", "max_breach_length", "GrowthEquation",
           "MaxLengthEquation", "GrowthInputs"]
