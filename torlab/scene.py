"""Scene files: the contact, materials, kinematics and product parameters of a prediction.

The keys are a contract with users and external checks (``docs/model/scene-contract.md``);
``docs/scenes.md`` documents every key.  A scene is one YAML file or several
merged in order (a base scene plus a parameter file written by ``torlab fit``):
later files override earlier ones key by key.

Every quantity is a plain number in SI units or a string with a unit
(``"20 kN"``, ``"0.373 mm"``, ``"1 mPa*s"``, ``"21500 mm^-2"``, ``"20 degC"``).
Unknown keys, missing keys, wrong units and physically impossible values are
reported all at once, each naming the file, line and key
(:class:`~torlab.errors.ValidationErrors`).

>>> scene = load_scene("protocols/scenes/wheel_rail_tab54.yaml")   # doctest: +SKIP
>>> scene.contact.load, scene.boundary.mu_c2                        # doctest: +SKIP
(20000.0, 0.45)
"""

from __future__ import annotations

import copy
import math
import os
from collections.abc import Sequence
from typing import Annotated, Any, Literal, Union

from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Discriminator,
    Field,
    Tag,
    ValidationError,
    model_serializer,
    model_validator,
)

from torlab.errors import TorlabInputError, ValidationErrors

__all__ = [
    "Boundary",
    "Contact",
    "FitCovariance",
    "FitProvenance",
    "Grid",
    "Kinematics",
    "Lubricant",
    "Materials",
    "Roughness",
    "Scene",
    "Thermal",
    "boundary_of",
    "load_scene",
    "scene_from_dict",
]


def _q(kind: str, *, allow_inf: bool = False):
    """A pydantic before-validator turning a user quantity into SI via torlab.units."""

    def conv(v: Any) -> Any:
        from torlab.units import to_si

        if v is None:
            return v
        try:
            return to_si(v, kind, allow_inf=allow_inf)
        except TorlabInputError as e:
            raise ValueError(e.message) from None

    return BeforeValidator(conv)


Length = Annotated[float, _q("length")]
LengthOrInf = Annotated[float, _q("length", allow_inf=True)]
Force = Annotated[float, _q("force")]
Pressure = Annotated[float, _q("pressure")]
InvPressure = Annotated[float, _q("inverse_pressure")]
Velocity = Annotated[float, _q("velocity")]
Viscosity = Annotated[float, _q("viscosity")]
Temperature = Annotated[float, _q("temperature")]
InvTemperature = Annotated[float, _q("inverse_temperature")]
Dimensionless = Annotated[float, _q("dimensionless")]
Conductivity = Annotated[float, _q("conductivity")]
Density = Annotated[float, _q("density")]
HeatCapacity = Annotated[float, _q("heat_capacity")]
ArealDensity = Annotated[float, _q("areal_density")]


class _Section(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, populate_by_name=True)


class Contact(_Section):
    """``contact:``: normal load and geometry (radii for Hertz, or the semi-axes directly).

    Attributes
    ----------
    load
        Normal force F (N), > 0.
    r1x, r1y, r2x, r2y
        Principal radii (m) of body 1 (wheel/ball) and body 2 (rail/disc) in the
        rolling (x) and lateral (y) direction; ``inf`` for a flat direction
        (thesis Eqs. 5.5-5.6).  Missing radii are flat.
    a, b
        Semi-axes (m) in the rolling and lateral direction; when given they are
        used instead of Hertz (then ``p0 = 3F/(2 pi a b)``).
    hertz
        ``approximate`` (thesis Eqs. 5.8-5.12, Hamrock-Brewe) or ``exact``
        (complete elliptic integrals).
    """

    load: Force = Field(gt=0)
    r1x: LengthOrInf = Field(default=math.inf, gt=0)
    r1y: LengthOrInf = Field(default=math.inf, gt=0)
    r2x: LengthOrInf = Field(default=math.inf, gt=0)
    r2y: LengthOrInf = Field(default=math.inf, gt=0)
    a: Length | None = Field(default=None, gt=0)
    b: Length | None = Field(default=None, gt=0)
    hertz: Literal["approximate", "exact"] = "approximate"

    @model_validator(mode="after")
    def _geometry(self) -> Contact:
        if (self.a is None) != (self.b is None):
            raise ValueError("give both semi-axes a and b, or neither (then Hertz computes them)")
        if self.a is None:
            cx = 1 / self.r1x + 1 / self.r2x
            cy = 1 / self.r1y + 1 / self.r2y
            if cx <= 0 or cy <= 0:
                raise ValueError("need a finite radius in the rolling direction (r1x or r2x) and in "
                                 "the lateral direction (r1y or r2y), or the semi-axes a and b")
        return self

    @property
    def has_radii(self) -> bool:
        """Whether the reduced radius in the rolling direction is finite (needed by EHL)."""
        return (1 / self.r1x + 1 / self.r2x) > 0

    @property
    def rx(self) -> float:
        """Reduced radius in the rolling direction ``1/rx = 1/r1x + 1/r2x`` (Eq. 5.5), m."""
        c = 1 / self.r1x + 1 / self.r2x
        return math.inf if c == 0 else 1 / c

    @property
    def ry(self) -> float:
        """Reduced radius in the lateral direction ``1/ry = 1/r1y + 1/r2y`` (Eq. 5.6), m."""
        c = 1 / self.r1y + 1 / self.r2y
        return math.inf if c == 0 else 1 / c


class Materials(_Section):
    """``materials:``: Young's moduli (Pa) and Poisson's ratios of both bodies."""

    E1: Pressure = Field(gt=0)
    nu1: Dimensionless = Field(ge=0, lt=0.5)
    E2: Pressure = Field(gt=0)
    nu2: Dimensionless = Field(ge=0, lt=0.5)


class Kinematics(_Section):
    """``kinematics:``: rolling (entrainment) speed ``v = (x1' + x2')/2`` and ambient temperature."""

    speed: Velocity = Field(default=1.0, ge=0)
    ambient_temperature: Temperature = 20.0


class Thermal(_Section):
    """``thermal:``: flash temperature of thesis 5.2.5 (Eqs. 5.49-5.50), docs/model/thesis-reading.md.

    Attributes
    ----------
    conductivity, density, heat_capacity
        lambda (W/(m K)), rho (kg/m^3), c (J/(kg K)); defaults from Tab. 5.4.
    partition
        Fraction of the frictional heat flowing into the body whose temperature
        is computed: 1 (the thesis) or e.g. 0.5 for equal materials (Ertz and
        Knothe split by effusivity).
    slip_velocity
        ``rigid`` (the thesis: q = tau w) or ``local`` (q = tau w only where the
        layer slides, zero in the elastic zone).
    tolerance
        Convergence of the tau-T iteration, max |Delta T| (K).
    max_iterations
        Iteration budget before :class:`~torlab.errors.ConvergenceError`.
    """

    conductivity: Conductivity = Field(default=50.0, gt=0)
    density: Density = Field(default=7850.0, gt=0)
    heat_capacity: HeatCapacity = Field(default=450.0, gt=0)
    partition: Dimensionless = Field(default=1.0, gt=0, le=1)
    slip_velocity: Literal["rigid", "local"] = "rigid"
    tolerance: Annotated[float, _q("temperature_difference")] = Field(default=0.1, gt=0)
    max_iterations: int = Field(default=200, ge=1, le=100_000)


class Boundary(_Section):
    """``boundary:``: the third-body layer (``docs/model/layers.md``).

    ``law`` names the layer law (:mod:`torlab.model.layers`; default: Voce, thesis
    Eqs. 5.24-5.29); the other keys are that law's parameters, generated from the
    registry (one subclass per law, chosen by ``law``).
    """

    law: str = "voce"

    def __new__(cls, *args: Any, **data: Any) -> Any:
        # Boundary(mu_c1=..., ...) builds the section of its law (``law=``, default Voce)
        if cls is Boundary:
            law = data.get("law", _DEFAULT_LAW)
            if law not in BOUNDARY_MODELS:
                raise ValueError(f"{law!r} is not a layer law ({', '.join(BOUNDARY_MODELS)})")
            return BOUNDARY_MODELS[law](**data)
        return super().__new__(cls)

    def __init__(self, **data: Any) -> None:
        if self.__dict__:  # built (and validated) by __new__ already
            return
        super().__init__(**data)

    @property
    def layer(self) -> Any:
        """The values as :class:`~torlab.model.layers.LayerParams` (SI)."""
        from torlab.model.layers import LayerParams

        return LayerParams(law=self.law, **{n: getattr(self, n) for n in self._names()})

    @classmethod
    def _names(cls) -> tuple[str, ...]:
        return tuple(n for n in cls.model_fields if n != "law")

    @model_serializer(mode="wrap")
    def _dump(self, handler: Any) -> Any:
        # the default law is not written: a Voce boundary dumps as it always has
        d = handler(self)
        if isinstance(d, dict) and d.get("law") == _DEFAULT_LAW:
            d.pop("law")
        return d


def _boundary_models() -> tuple[str, dict[str, type[Boundary]]]:
    """One :class:`Boundary` subclass per layer law (its parameters as fields)."""
    from pydantic import create_model

    # the layer laws' registry sits below the scene (it imports nothing of the model): each
    # law declares its boundary: keys, units and ranges there, and the scene validates them
    from torlab.model.layers import DEFAULT_LAW, LAWS

    models: dict[str, type[Boundary]] = {}
    for name, law in LAWS.items():
        fields: dict[str, Any] = {}
        for prm in law.params:
            tp = Annotated[float, _q(prm.kind)]
            fields[prm.name] = (tp, Field(default=... if prm.default is None else prm.default,
                                          ge=prm.ge, le=prm.le, description=prm.meaning))
        fields["law"] = (Literal[name], name)  # type: ignore[valid-type]
        models[name] = create_model(f"Boundary_{name}", __base__=Boundary,
                                    __doc__=f"``boundary:`` with the {name} layer law "
                                            f"({law.title}).", **fields)
    return DEFAULT_LAW, models


_DEFAULT_LAW, BOUNDARY_MODELS = _boundary_models()
# importable by name (scenes are pickled for worker processes)
globals().update({m.__name__: m for m in BOUNDARY_MODELS.values()})


def _law_of(v: Any) -> str:
    if isinstance(v, dict):
        law = v.get("law", _DEFAULT_LAW)
        return law if isinstance(law, str) else repr(law)
    return getattr(v, "law", _DEFAULT_LAW)


def boundary_of(layer: Any) -> Boundary:
    """The ``boundary:`` section of a :class:`~torlab.model.layers.LayerParams` (scalars;
    the inverse of :attr:`Boundary.layer`)."""
    return BOUNDARY_MODELS[layer.law.name](**{k: float(v) for k, v in layer.values.items()})


if len(BOUNDARY_MODELS) == 1:
    BoundaryField = next(iter(BOUNDARY_MODELS.values()))
else:
    BoundaryField = Annotated[Union[tuple(Annotated[m, Tag(n)]  # noqa: UP007
                                          for n, m in BOUNDARY_MODELS.items())],
                              Discriminator(_law_of)]


#: -ln(eta_inf / 1 Pa s) of the Roelands law (Eq. 5.38), as torlab.model.viscosity has it
#: (the scene is read below the models, so the number is written here too; a test keeps
#: the two equal)
ROELANDS_C = 9.67


class Lubricant(_Section):
    """``lubricant:``: viscosity law, film formula and EHL shear law (thesis 5.2.3).

    Attributes
    ----------
    eta0
        Viscosity at ambient pressure (Pa s).
    viscosity
        ``iso`` (constant), ``barus`` (Eq. 5.39) or ``roelands`` (Eq. 5.38).
    alpha
        Pressure-viscosity coefficient (1/Pa): Barus, and G in Hamrock-Dowson.
    Z
        Roelands index.
    film
        ``iso`` (Esfahanian-Hamrock, Eq. 5.31) or ``piezo`` (Hamrock-Dowson,
        Eq. 5.32); default: ``iso`` for an iso-viscous lubricant, ``piezo``
        otherwise.
    shear
        ``newtonian`` (Eq. 5.37), ``limiting`` (tau <= gamma_L p) or ``eyring``
        (tau0 asinh(eta w / (h tau0))).
    gamma_L, tau0
        Parameters of the limiting and the Eyring shear law.
    """

    eta0: Viscosity = Field(gt=0)
    viscosity: Literal["iso", "barus", "roelands"] = "iso"
    alpha: InvPressure | None = Field(default=None, ge=0)
    Z: Dimensionless | None = Field(default=None, gt=0)
    film: Literal["iso", "piezo"] | None = None
    shear: Literal["newtonian", "limiting", "eyring"] = "newtonian"
    gamma_L: Dimensionless | None = Field(default=None, gt=0)
    tau0: Pressure | None = Field(default=None, gt=0)

    @model_validator(mode="after")
    def _laws(self) -> Lubricant:
        if self.viscosity == "barus" and self.alpha is None:
            raise ValueError("viscosity: barus needs alpha (e.g. '15 1/GPa')")
        if self.viscosity == "roelands" and self.Z is None:
            raise ValueError("viscosity: roelands needs Z (e.g. 0.6)")
        if self.Z is not None and math.log(self.eta0) + ROELANDS_C <= 0:
            # Eq. 5.38 with eta0 at or below eta_inf
            raise ValueError(f"eta0: the Roelands law (Z) needs eta0 above its eta_inf "
                             f"{math.exp(-ROELANDS_C) * 1e3:.3g} mPa*s, got "
                             f"{self.eta0 * 1e3:.3g} mPa*s")
        if self.film_law == "piezo" and self.alpha is None and self.Z is None:
            raise ValueError("film: piezo (Hamrock-Dowson) needs alpha or Z for G = alpha E'")
        if self.shear == "limiting" and self.gamma_L is None:
            raise ValueError("shear: limiting needs gamma_L (limiting shear stress / pressure, e.g. 0.08)")
        if self.shear == "eyring" and self.tau0 is None:
            raise ValueError("shear: eyring needs tau0 (Eyring stress, e.g. '5 MPa')")
        return self

    @property
    def film_law(self) -> str:
        """The film-thickness formula in use (``iso`` or ``piezo``)."""
        if self.film is not None:
            return self.film
        return "iso" if self.viscosity == "iso" else "piezo"


class Roughness(_Section):
    """``roughness:``: Greenwood-Williamson asperities (thesis 5.2.4, Tab. 5.1)."""

    sigma: Length = Field(gt=0)
    beta: Length = Field(gt=0)
    density: ArealDensity = Field(gt=0)
    model: Literal["elastic", "plastic"] = "plastic"
    hardness: Pressure | None = Field(default=None, gt=0)

    @model_validator(mode="after")
    def _hardness(self) -> Roughness:
        if self.model == "plastic" and self.hardness is None:
            raise ValueError("model: plastic needs hardness (e.g. '6 GPa')")
        return self


class Grid(_Section):
    """``grid:``: numerical resolution of FASTSIM (defaults meet the 0.1 % accuracy goal)
    and the boundary method.

    Attributes
    ----------
    n
        Gauss nodes across the half contact (strips); symmetry doubles them.
    m
        Gauss nodes per panel along a strip.
    scheme
        ``gauss`` (torlab's default, see :mod:`torlab.model.fastsim`).
    temperature_nodes
        Nodes per strip of the temperature grid.
    method
        The boundary method (``docs/model/boundary.md``): ``fastsim`` (default,
        FASTSIM corrected by Kalker's exact theory, :mod:`torlab.model.calibrated`),
        ``fastsim-kalker`` (Kalker's FASTSIM, the thesis's model), ``exact`` (Kalker's
        exact theory, :mod:`torlab.model.exact`) or ``auto`` (``fastsim`` where its
        theory error is below the band's half-width, ``exact`` elsewhere).
    exact_n
        Elements across each axis of the ellipse for the exact solver (its error is
        estimated from a second grid of ``0.6 exact_n``).
    """

    n: int = Field(default=6, ge=2, le=2000)
    m: int = Field(default=4, ge=2, le=64)
    scheme: Literal["gauss"] = "gauss"
    temperature_nodes: int = Field(default=48, ge=8, le=4000)
    method: Literal["fastsim", "fastsim-kalker", "exact", "auto"] = "fastsim"
    exact_n: int = Field(default=25, ge=8, le=200)


class FitCovariance(_Section):
    """``fit: covariance:``: the uncertainty of a fit's parameters (written by ``torlab fit``).

    Predictions draw their bands from it (:mod:`torlab.model.bands`).

    Attributes
    ----------
    names
        Parameter names (the scene's ``boundary:`` / ``lubricant:`` keys where
        they have one; others are carried but not used by predictions).
    values
        The estimates the covariance belongs to (SI).  A scene value that
        differs (a later file overrides it) is treated as exact.
    matrix
        Covariance (SI units), symmetric positive semi-definite.
    log_scale
        Positive parameters whose uncertainty is propagated as ``ln p``.
    dof
        Residual degrees of freedom of the covariance (Student t; ``.inf`` for normal).
    not_determined
        Parameters the fit did not determine (no finite variance): a band that
        depends on them cannot be drawn.
    """

    names: list[str] = Field(min_length=1)
    values: list[float]
    matrix: list[list[float]]
    log_scale: list[str] = Field(default_factory=list)
    dof: float = Field(default=math.inf, gt=0)
    not_determined: list[str] = Field(default_factory=list)

    @model_validator(mode="after")
    def _shape(self) -> FitCovariance:
        import numpy as np

        k = len(self.names)
        if len(set(self.names)) != k:
            raise ValueError("covariance names repeat")
        if len(self.values) != k:
            raise ValueError(f"{k} names but {len(self.values)} values")
        if len(self.matrix) != k or any(len(r) != k for r in self.matrix):
            raise ValueError(f"the covariance matrix must be {k} x {k} (one row per name)")
        c = np.asarray(self.matrix, dtype=float)
        if not (np.all(np.isfinite(c)) and all(math.isfinite(v) for v in self.values)):
            raise ValueError("covariance values and matrix must be finite numbers")
        scale = max(float(np.max(np.abs(np.diag(c)), initial=0.0)), 1e-300)
        if not np.allclose(c, c.T, rtol=1e-6, atol=1e-9 * scale):
            raise ValueError("the covariance matrix is not symmetric")
        d = np.sqrt(np.clip(np.diag(c), 0.0, None))
        if np.any(np.diag(c) < 0) or np.linalg.eigvalsh(
                c / np.outer(np.where(d > 0, d, 1.0), np.where(d > 0, d, 1.0))).min() < -1e-6:
            raise ValueError("the covariance matrix is not positive semi-definite")
        bad = [n for n in self.log_scale if n not in self.names]
        if bad:
            raise ValueError(f"log_scale names {bad} are not in names")
        for n in self.log_scale:
            if not self.values[self.names.index(n)] > 0:
                raise ValueError(f"{n} is on a log scale but its value is not positive")
        if set(self.not_determined) & set(self.names):
            raise ValueError("a parameter is both in names and not_determined")
        return self


class FitProvenance(BaseModel):
    """``fit:``: provenance written by ``torlab fit`` (free-form) with a validated ``covariance:``.

    Reads like the dict it used to be (``scene.fit["kind"]``).  When several
    parameter files each bring a covariance, :func:`load_scene` keeps them all
    (a list, one independent block per file, later files first in precedence).
    """

    model_config = ConfigDict(extra="allow", frozen=True)

    #: one block per parameter file (a single mapping in a file is read as one block)
    covariance: Annotated[list[FitCovariance] | None, BeforeValidator(
        lambda v: [v] if isinstance(v, dict) else v)] = None

    @property
    def covariances(self) -> list[FitCovariance]:
        """The covariance blocks, in file order (empty without any)."""
        return list(self.covariance or [])

    def _as_dict(self) -> dict[str, Any]:
        return self.model_dump(exclude_none=True)

    def __getitem__(self, key: str) -> Any:
        return self._as_dict()[key]

    def __contains__(self, key: object) -> bool:
        return key in self._as_dict()

    def get(self, key: str, default: Any = None) -> Any:
        """Like ``dict.get``."""
        return self._as_dict().get(key, default)


class Scene(_Section):
    """A whole scene (``docs/model/scene-contract.md``)."""

    name: str = ""
    description: str = ""
    contact: Contact
    materials: Materials
    kinematics: Kinematics = Kinematics()
    thermal: Thermal | None = None
    boundary: BoundaryField | None = None  # type: ignore[valid-type]
    lubricant: Lubricant | None = None
    roughness: Roughness | None = None
    grid: Grid = Grid()
    fit: FitProvenance | None = Field(default=None, description="provenance written by torlab fit")

    @model_validator(mode="after")
    def _needs(self) -> Scene:
        if self.boundary is None and (self.lubricant is None or self.roughness is not None):
            raise ValueError("needs a 'boundary:' section (the third-body layer) unless it is a "
                             "smooth lubricated contact")
        if self.lubricant is not None and not self.contact.has_radii:
            raise ValueError("a lubricated scene needs the radius in the rolling direction "
                             "(r1x and/or r2x) for the film thickness")
        return self


# --- loading ---------------------------------------------------------------------------------
def _merge(base: dict, over: dict, origin: dict, over_origin: dict, prefix: tuple = ()) -> None:
    for k, v in over.items():
        kp = (*prefix, k)
        if isinstance(v, dict) and isinstance(base.get(k), dict):
            _merge(base[k], v, origin, over_origin, kp)
        else:
            base[k] = v
            for okey in [o for o in list(origin) if o[: len(kp)] == kp]:
                del origin[okey]
        for okey, loc in over_origin.items():
            if okey[: len(kp)] == kp:
                origin[okey] = loc


def scene_from_dict(data: Any, *, origin: dict[tuple, tuple[str | None, int | None]] | None = None,
                    path: str | None = None) -> Scene:
    """Validate a scene given as a dict (e.g. built in a notebook).

    ``origin`` maps key paths to ``(file, line)`` for error messages.

    Raises
    ------
    ValidationErrors
        Every problem, each naming file, line and key.
    """
    origin = origin or {}
    if not isinstance(data, dict):
        raise TorlabInputError("a scene must be a YAML mapping with contact:, materials: ... sections",
                               path=path)
    data = {k: ("off" if v is False else v) for k, v in data.items()}
    if data.get("thermal") in ("off", "none", None):
        data.pop("thermal", None)
    try:
        scene = Scene.model_validate(data)
    except ValidationError as ve:
        problems = []
        for err in ve.errors():
            loc = tuple(x for x in err["loc"] if not (isinstance(x, str) and x.startswith("function-")))
            # pydantic appends the literal/union branch name; drop non-key parts
            loc = tuple(x for x in loc if x not in ("float", "int", "str", "dict[str,any]"))
            if loc[:1] == ("boundary",) and len(loc) > 1 and loc[1] in BOUNDARY_MODELS:
                err = {**err, "law": loc[1]}
                loc = loc[:1] + loc[2:]  # the layer law's tag is not a key
            file, line = _origin_of(loc, origin, path)
            key = ".".join(str(x) for x in loc) or None
            raw = _lookup(data, loc)
            if raw is not _MISSING:
                err = {**err, "input": raw}
            problems.append(TorlabInputError(_message(err), path=file, line=line, key=key))
        problems.sort(key=lambda e: (e.path or "", e.line or 0))
        raise ValidationErrors(problems) from None
    _check_ranges(scene, origin, path)
    return scene


def _layer_params() -> dict[str, Any]:
    from torlab.model.layers import all_params

    return all_params()


def _range(fields: dict[str, Any]) -> Any:
    """The :class:`~torlab.units.Range` a layer law declares for its own parameter."""
    from torlab.units import Range

    return Range(**fields)


#: scene key -> plausible-range quantity of torlab.units.RANGES (docs/scenes.md), or the
#: :class:`~torlab.units.Range` a layer law declares for its own parameter
SCENE_RANGES: dict[tuple[str, str], Any] = {
    ("contact", "load"): "load",
    **{("contact", k): "radius" for k in ("r1x", "r1y", "r2x", "r2y")},
    ("contact", "a"): "semi_axis", ("contact", "b"): "semi_axis",
    ("materials", "E1"): "modulus", ("materials", "E2"): "modulus",
    ("kinematics", "speed"): "speed", ("kinematics", "ambient_temperature"): "temperature",
    ("thermal", "conductivity"): "conductivity", ("thermal", "density"): "density",
    ("thermal", "heat_capacity"): "heat_capacity",
    ("thermal", "tolerance"): "temperature_difference",
    # the layer laws' parameters with a plausible range (torlab.model.layers), in order
    **{("boundary", n): prm.range if isinstance(prm.range, str) else _range(prm.range)
       for n, prm in _layer_params().items() if prm.range},
    ("lubricant", "eta0"): "viscosity", ("lubricant", "alpha"): "pressure_viscosity",
    ("lubricant", "tau0"): "stress",
    ("roughness", "sigma"): "roughness", ("roughness", "beta"): "asperity_radius",
    ("roughness", "density"): "asperity_density", ("roughness", "hardness"): "stress",
}


def _check_ranges(scene: Scene, origin: dict, path: str | None) -> None:
    """Every quantity against :data:`torlab.units.RANGES`: impossible values are errors
    (all listed at once), unusual ones a :class:`~torlab.errors.TorlabWarning` each."""
    from torlab.units import check_range

    problems = []
    for (section, key), quantity in SCENE_RANGES.items():
        sec = getattr(scene, section)
        v = None if sec is None else getattr(sec, key, None)  # None: not this layer law's
        if v is None:
            continue
        file, line = _origin_of((section, key), origin, path)
        try:
            check_range(quantity, float(v), where=f"{section}.{key}", path=file, line=line,
                        allow_inf=quantity == "radius")
        except TorlabInputError as e:
            problems.append(e)
    if problems:
        problems.sort(key=lambda e: (e.path or "", e.line or 0))
        raise ValidationErrors(problems)


_MISSING = object()


def _lookup(data: Any, loc: tuple) -> Any:
    cur = data
    for k in loc:
        if isinstance(cur, dict) and k in cur:
            cur = cur[k]
        else:
            return _MISSING
    return cur


def _origin_of(loc: tuple, origin: dict, path: str | None) -> tuple[str | None, int | None]:
    kp = loc
    while kp:
        if kp in origin:
            return origin[kp]
        kp = kp[:-1]
    return origin.get((), (path, None))


def _message(err: dict) -> str:
    t = err.get("type", "")
    msg = err.get("msg", "")
    if t == "union_tag_invalid":
        from torlab._suggest import did_you_mean

        tag = (err.get("ctx") or {}).get("tag", "")
        return (f"{tag} is not a layer law: use {', '.join(BOUNDARY_MODELS)}"
                f"{did_you_mean(tag.strip(chr(39)), BOUNDARY_MODELS)}")
    if t == "extra_forbidden" and "law" in err:
        return _boundary_key_message(err)
    if t == "extra_forbidden":
        from torlab._suggest import key_suggestion

        return "unknown key" + key_suggestion(Scene, tuple(err.get("loc", ())))
    if t == "missing":
        return "missing (required)"
    if t == "literal_error":
        from torlab._suggest import literal_suggestion

        return (f"{err.get('input')!r} is not allowed: {msg.replace('Input should be ', 'use ')}"
                f"{literal_suggestion(err)}")
    if t in ("greater_than", "greater_than_equal", "less_than", "less_than_equal"):
        return f"{err.get('input')!r} is out of range: {msg.replace('Input should be ', 'must be ')}"
    if msg.startswith("Value error, "):
        return msg[len("Value error, "):]
    return msg


def _boundary_key_message(err: dict) -> str:
    """An unknown ``boundary:`` key: a parameter of another layer law, or a typo."""
    from torlab._suggest import did_you_mean
    from torlab.model.layers import LAWS

    law = err["law"]
    key = str(err.get("loc", ("",))[-1])
    owners = [n for n, lw in LAWS.items() if key in lw.names]
    if owners:
        return (f"not a parameter of the {law} layer law ({', '.join(LAWS[law].names)}); "
                f"{key} belongs to {' and '.join(owners)} (set law: {owners[0]})")
    return "unknown key" + did_you_mean(key, [*LAWS[law].names, "law"])


def _switch_law(merged: dict, over: dict, origin: dict) -> None:
    """A later file that sets another layer law replaces the layer: the earlier files'
    ``boundary:`` keys that the new law does not have are dropped before the merge."""
    from torlab.model.layers import LAWS

    new, old = over.get("boundary"), merged.get("boundary")
    if not (isinstance(new, dict) and isinstance(old, dict) and "law" in new):
        return
    law = new["law"]
    if law == old.get("law", _DEFAULT_LAW) or law not in LAWS:
        return
    keep = set(LAWS[law].names)
    for k in [k for k in old if k not in keep]:
        del old[k]
        origin.pop(("boundary", k), None)


def load_scene(*paths: str | os.PathLike[str] | Sequence[str]) -> Scene:
    """Read and validate a scene from one or more YAML files merged in order.

    Parameters
    ----------
    *paths
        Scene file, then optional parameter files (e.g. ``torlab fit`` output)
        whose keys override the earlier files'.

    Returns
    -------
    Scene
        All quantities in SI units (temperatures in degC).

    Raises
    ------
    TorlabInputError / ValidationErrors
        Unreadable or invalid YAML, unknown or missing keys, wrong units,
        impossible values: every problem with file, line and key.
    """
    from torlab.yamlio import load_yaml

    if len(paths) == 1 and isinstance(paths[0], (list, tuple)):
        paths = tuple(paths[0])
    if not paths:
        raise TorlabInputError("no scene file given")
    merged: dict = {}
    origin: dict[tuple, tuple[str | None, int | None]] = {}
    covariances: list[Any] = []  # one per parameter file: independent fits, all kept
    for p in paths:
        doc = load_yaml(p)
        if doc.data is None:
            raise TorlabInputError("scene file is empty", path=doc.path)
        if not isinstance(doc.data, dict):
            raise TorlabInputError("a scene must be a YAML mapping with contact:, materials: ... "
                                   "sections", path=doc.path, line=doc.lines.line(()))
        file_origin = {k: (doc.path, ln) for k, ln in doc.lines.lines.items() if k}
        if not origin:
            origin[()] = (doc.path, 1)
        fit = doc.data.get("fit")
        if isinstance(fit, dict) and fit.get("covariance") is not None:
            c = copy.deepcopy(fit["covariance"])  # merging later files changes it in place
            covariances.extend(c if isinstance(c, list) else [c])
        _switch_law(merged, doc.data, origin)
        _merge(merged, doc.data, origin, file_origin)
    if len(covariances) > 1:
        merged["fit"]["covariance"] = covariances
    return scene_from_dict(merged, origin=origin, path=os.fspath(paths[0]))
