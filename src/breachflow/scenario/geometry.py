"""Levee and breach geometry (docs/theory.md, *Units and notation*, *Breach growth*; report §2.5–2.8, Figs 2.10–2.11, 3.2).

Plain dataclasses of SI floats. Construct them from user input with :meth:`LeveeGeometry.from_input`
/ :meth:`BreachGeometry.from_input`, which accept numbers with units. The hydrodynamic terrain builder
(:mod:`breachflow.swe.domain`) turns a :class:`BreachScene` into a bed-elevation grid.
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields, asdict

from ..errors import InputError
from ..units import to_si

#: the breach wall slope m_W (horizontal run per unit rise, H per V) wherever a breach is not given
#: explicitly: the report's "mostly 2V:1H", i.e. 1V:0.5H (docs/theory.md, *Breach growth*). The one
#: default of ``[breach] wall_slope``, ``[site] breach_wall_slope``, the weir discharge, the fill volume
#: and stone sizing, and the closure timeline.
DEFAULT_WALL_SLOPE = 0.5


def _from_input(cls, kinds: dict, values: dict):
    unknown = set(values) - {f.name for f in fields(cls)}
    if unknown:
        raise InputError(f"{cls.__name__}: unknown parameter(s) {sorted(unknown)}; allowed: {[f.name for f in fields(cls)]}")
    out = {}
    for name, v in values.items():
        kind, default_unit, check = kinds[name]
        out[name] = to_si(v, name=name, kind=kind, default_unit=default_unit, **check)
    return cls(**out)


@dataclass(frozen=True)
class LeveeGeometry:
    """Trapezoidal levee cross-section.

    ``height`` h_L (m), ``crown_width`` b (m), side slopes as horizontal run per unit rise
    (1V:mH → m) on the flood side ``flood_slope`` m_F and protected side ``protected_slope`` m_P.
    Cross-sectional area A_L = h_L (b + h_L (m_F + m_P) / 2) (m², i.e. m³ per m of levee).
    """

    height: float
    crown_width: float
    flood_slope: float
    protected_slope: float

    def __post_init__(self):
        for f in fields(self):
            v = getattr(self, f.name)
            if not v == v or v < 0 or (f.name == "height" and v == 0):
                raise InputError(f"LeveeGeometry.{f.name} must be {'> 0' if f.name == 'height' else '>= 0'}, got {v}")

    @property
    def area(self) -> float:
        """A_L, levee cross-sectional area (m²)."""
        return self.height * (self.crown_width + 0.5 * self.height * (self.flood_slope + self.protected_slope))

    @property
    def base_width(self) -> float:
        """Footprint width of the levee (m)."""
        return self.crown_width + self.height * (self.flood_slope + self.protected_slope)

    @classmethod
    def from_input(cls, **values) -> "LeveeGeometry":
        """Build from numbers with units, e.g. ``height="25 ft", crown_width="3 m", flood_slope=4``."""
        kinds = {"height": ("length", None, {"positive": True}), "crown_width": ("length", None, {"nonnegative": True}),
                 "flood_slope": ("dimensionless", "", {"nonnegative": True}),
                 "protected_slope": ("dimensionless", "", {"nonnegative": True})}
        return _from_input(cls, kinds, values)


@dataclass(frozen=True)
class BreachGeometry:
    """Trapezoidal breach through the levee.

    ``length`` B along the levee centreline at the crest (m), ``depth`` D below the crest (m; equal to
    the levee height when the breach reaches the ground), ``wall_slope`` m_W (horizontal run per unit
    rise; 0 is vertical; default :data:`~breachflow.scenario.geometry.DEFAULT_WALL_SLOPE`, the report's mostly 2V:1H), ``scour_depth`` d_S below ground (m).
    """

    length: float
    depth: float
    wall_slope: float = DEFAULT_WALL_SLOPE
    scour_depth: float = 0.0

    def __post_init__(self):
        if not self.length > 0:
            raise InputError(f"BreachGeometry.length must be > 0, got {self.length}")
        if not self.depth > 0:
            raise InputError(f"BreachGeometry.depth must be > 0, got {self.depth}")
        if not (self.wall_slope >= 0 and self.scour_depth >= 0):
            raise InputError("BreachGeometry.wall_slope and scour_depth must be >= 0")
        if self.length - 2 * self.wall_slope * self.depth <= 0:
            raise InputError(
                f"BreachGeometry: walls of slope 1V:{self.wall_slope}H meet above the bottom "
                f"(length {self.length} m < 2 × {self.wall_slope} × depth {self.depth} m)"
            )

    @property
    def bottom_width(self) -> float:
        """Width of the breach bottom (m): B − 2 m_W D."""
        return self.length - 2.0 * self.wall_slope * self.depth

    def flow_area(self, water_depth: float) -> float:
        """Wetted cross-section of the trapezoid for a water depth above the breach bottom (m²)."""
        h = min(max(water_depth, 0.0), self.depth + self.scour_depth)
        return h * (self.bottom_width + self.wall_slope * h)

    @classmethod
    def from_input(cls, **values) -> "BreachGeometry":
        kinds = {"length": ("length", None, {"positive": True}), "depth": ("length", None, {"positive": True}),
                 "wall_slope": ("dimensionless", "", {"nonnegative": True}),
                 "scour_depth": ("length", None, {"nonnegative": True})}
        return _from_input(cls, kinds, values)


@dataclass(frozen=True)
class BreachScene:
    """The breach site: levee, breach, flood channel and polder (report §2.8, Fig 3.2).

    Elevations above the datum (m). The levee centreline is the line y = 0 in scene coordinates,
    flood side y < 0, protected side y > 0; the breach is centred at x = 0.
    """

    levee: LeveeGeometry
    breach: BreachGeometry
    ground_elevation: float
    flood_water_elevation: float
    levee_length_each_side: float
    flood_side_extent: float
    protected_side_extent: float
    flood_channel_length: float
    flood_channel_drop: float
    polder_slope: float
    manning_n: float
    name: str = ""
    notes: dict = field(default_factory=dict)

    @property
    def surge_height(self) -> float:
        """h_W: flood-side water height above the ground at the breach (m)."""
        return self.flood_water_elevation - self.ground_elevation

    def to_dict(self) -> dict:
        return asdict(self)


def typical_breach() -> BreachScene:
    """The report's "typical breach" (docs/theory.md, *Breach growth*; report §2.8, Fig 3.2), in the model's dimensions.

    Clay levee 7.6 m (25 ft) high, water at the crest (ground EL 30.5 m, water EL 38.1 m), crown 3.0 m,
    slopes 1V:4H, breach 61.0 m (200 ft) reaching the ground with vertical walls as in the ADH mesh,
    914.6 m of levee each side, flood channel 1890 m long with a 0.09 m water-surface drop, domain
    385 m flood side to 488 m protected side, polder slope 1V:4800H, Manning n = 0.025.
    """
    return BreachScene(
        levee=LeveeGeometry(height=7.6, crown_width=3.0, flood_slope=4.0, protected_slope=4.0),
        breach=BreachGeometry(length=61.0, depth=7.6, wall_slope=0.0, scour_depth=0.0),
        ground_elevation=30.5,
        flood_water_elevation=38.1,
        levee_length_each_side=914.6,
        flood_side_extent=385.0,
        protected_side_extent=488.0,
        flood_channel_length=1890.0,
        flood_channel_drop=0.09,
        polder_slope=1.0 / 4800.0,
        manning_n=0.025,
        name="typical_breach",
        notes={"source": "SERRI 70015-001 §2.8, Fig 3.2", "adh_peak_velocity_m_s": 6.1},
    )
