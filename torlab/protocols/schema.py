"""The test-protocol schema, version 1 (``docs/protocols.md`` documents every key).

A protocol is a YAML file that describes an experimental campaign: which raw
files of which instrument (``data:``), which parameters to identify from them
(``fits:``), and which reports to write (``reports:``).  The models below are
pydantic v2 models in strict mode with unknown keys forbidden: a misspelt key, a
quantity in the wrong unit, a missing file or a wrong ``version`` is an error
naming the file, line and key path, and every such problem is reported at once
(:func:`torlab.protocols.loader.load_protocol`).

Quantities are plain numbers in SI units or strings with a unit (``"20 um"``,
``"4 s"``, ``"930 kg/m^3"``, ``"25 degC"``, ``"5 %"``); paths are relative to the
protocol file and may be glob patterns (``../sample_data/hpt/hpt_*.txt``).
"""

from __future__ import annotations

import glob
import os
from pathlib import Path
from typing import Annotated, Any, ClassVar, Literal

from pydantic import (
    AfterValidator,
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    PrivateAttr,
    ValidationInfo,
    model_validator,
)

from torlab.errors import TorlabInputError

__all__ = [
    "DATA_SECTIONS",
    "PROTOCOL_VERSION",
    "AmountReport",
    "CurveSpec",
    "Data",
    "DataSection",
    "FileEntry",
    "FilmReport",
    "Fits",
    "HptLayerFit",
    "LubricantFit",
    "OptionGroup",
    "Product",
    "Protocol",
    "Reports",
    "RetentionPredictionSpec",
    "RetentionReport",
    "RetentionSweepSpec",
    "StribeckReport",
    "TimeTestReport",
    "TractionLayerFit",
    "TractionReport",
]

#: the protocol version this torlab reads
PROTOCOL_VERSION = 1


# --------------------------------------------------------------------------- quantities
def _q(kind: str, quantity: str | None = None):
    """Before-validator: a user quantity (number = SI, or string with unit) -> SI float.

    With ``quantity``, the value is also checked against
    :data:`torlab.units.RANGES` (impossible: an error; unusual: a warning).
    """

    def conv(v: Any) -> Any:
        from torlab.units import check_range, to_si

        if v is None:
            return v
        try:
            x = to_si(v, kind)
            return x if quantity is None else check_range(quantity, x)
        except TorlabInputError as e:
            raise ValueError(e.message) from None

    return BeforeValidator(conv)


Length = Annotated[float, _q("length")]
Time = Annotated[float, _q("time")]
Density = Annotated[float, _q("density", "density")]
Temperature = Annotated[float, _q("temperature", "temperature")]
Velocity = Annotated[float, _q("velocity")]
Viscosity = Annotated[float, _q("viscosity", "viscosity")]
Fraction = Annotated[float, _q("dimensionless")]


def _amount(v: Any) -> Any:
    """An applied amount: a volume (``4 uL``) or a mass (``4 mg``) -> ``(kind, SI value)``."""
    from torlab.units import known_kinds, to_si

    if isinstance(v, (int, float)) and not isinstance(v, bool):
        raise ValueError(f"{v!r}: give the amount with its unit, e.g. '4 uL' or '4 mg'")
    if not isinstance(v, str):
        return v
    known = known_kinds(v)  # a common unit's kind first (no pint for a failing try)
    for kind in sorted(("volume", "mass"), key=lambda k: k not in known):
        try:
            x = to_si(v, kind)
        except TorlabInputError:
            continue
        if x != 0:  # zero: the dry runs
            from torlab.units import check_range

            try:
                check_range(f"amount_{kind}", x)
            except TorlabInputError as e:
                raise ValueError(e.message) from None
        return (kind, x)
    raise ValueError(f"{v!r} is neither a volume (e.g. '4 uL') nor a mass (e.g. '4 mg')")


Amount = Annotated[tuple[Literal["volume", "mass"], float], BeforeValidator(_amount)]


def _grid_values(kind: str, *, positive: bool = False, quantity: str | None = None):  # noqa: C901 (its validator's cases)
    """Before-validator for a grid of values.

    Accepts a list of quantities, ``"start:stop:count"`` (inclusive, linear, like
    ``numpy.linspace``) or a mapping ``{from, to, points, spacing: linear|log}``.
    With ``quantity``, every value is checked against :data:`torlab.units.RANGES`.
    """

    def conv(v: Any) -> Any:  # noqa: C901 (each way a grid of values may be written is a case)
        import numpy as np

        from torlab.units import to_si

        try:
            if isinstance(v, str):
                from torlab.grids import parse_values

                vals = [float(x) for x in parse_values(v, kind, "grid")]
            elif isinstance(v, list):
                if not v:
                    raise ValueError("empty list")
                vals = [to_si(x, kind) for x in v]
            elif isinstance(v, dict):
                extra = set(v) - {"from", "to", "points", "spacing"}
                if extra:
                    raise ValueError(f"unknown key(s) {', '.join(sorted(map(str, extra)))} (a grid "
                                     "has from, to, points, spacing)")
                missing = [k for k in ("from", "to", "points") if k not in v]
                if missing:
                    raise ValueError(f"a grid needs {', '.join(missing)}")
                a, b = to_si(v["from"], kind), to_si(v["to"], kind)
                n = v["points"]
                if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= 100_000:
                    raise ValueError(f"points must be an integer 1-100000, got {n!r}")
                spacing = v.get("spacing", "linear")
                if spacing not in ("linear", "log"):
                    raise ValueError(f"spacing {spacing!r}: use linear or log")
                if spacing == "log":
                    if a <= 0 or b <= 0:
                        raise ValueError("a log-spaced grid needs positive from and to")
                    vals = [float(x) for x in np.geomspace(a, b, n)]
                else:
                    vals = [float(x) for x in np.linspace(a, b, n)]
            else:
                raise ValueError("give a list of values, 'start:stop:count' or "
                                 "{from, to, points, spacing}")
        except TorlabInputError as e:
            raise ValueError(e.message) from None
        if positive and any(x <= 0 for x in vals):
            raise ValueError("values must be positive")
        if quantity is not None:
            from torlab.units import check_range

            try:
                for x in vals:
                    check_range(quantity, x)
            except TorlabInputError as e:
                raise ValueError(e.message) from None
        return vals

    return BeforeValidator(conv)


# --------------------------------------------------------------------------- base
class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True, frozen=True)


def _base(info: ValidationInfo) -> Path:
    ctx = info.context or {}
    return Path(ctx.get("base", "."))


_GLOB_CHARS = set("*?[")


def resolve_paths(pattern: str, base: Path) -> list[Path]:
    """Files named by ``pattern`` (relative to ``base``; glob characters allowed), sorted.

    Raises
    ------
    ValueError
        No such file, a folder, or a glob that matches nothing.
    """
    p = Path(os.path.expanduser(pattern))
    full = p if p.is_absolute() else base / p
    if _GLOB_CHARS & set(pattern):
        folder, name = os.path.split(str(full))
        if _GLOB_CHARS & set(folder):
            hits = sorted(Path(h) for h in glob.glob(str(full)) if Path(h).is_file())
        else:  # one folder: one scan of it, the file types from the scan (no stat per file)
            hits = [Path(folder, n) for n in sorted(_match_files(folder, name))]
        if not hits:
            raise ValueError(f"no file matches {pattern!r} (looked in {full.parent})")
        return hits
    if not full.exists():
        raise ValueError(f"file not found: {pattern} (looked for {full})")
    if full.is_dir():
        raise ValueError(f"{pattern} is a folder, expected a file")
    return [full]


def _match_files(folder: str, pattern: str) -> list[str]:
    """Names of the files in ``folder`` matching the glob ``pattern`` (as :func:`glob.glob`
    matches them: hidden names only by a pattern starting with a dot; a link counts as
    the file it points to)."""
    import fnmatch

    try:
        with os.scandir(folder or os.curdir) as it:
            entries = [e for e in it if not e.name.startswith(".") or pattern.startswith(".")]
    except OSError:
        return []
    names = set(fnmatch.filter([e.name for e in entries], pattern))
    return [e.name for e in entries if e.name in names and e.is_file()]


def _file_entry(v: Any) -> Any:
    return {"path": v} if isinstance(v, str) else v


class FileEntry(_Model):
    """One entry of a ``files:`` list: a path or glob, optionally with a label.

    Written either as a plain string (``- ../data/run1.txt``) or as a mapping
    (``- {path: ../data/run1.txt, label: base oil}``).
    """

    path: str = Field(min_length=1)
    label: str = ""
    _resolved: list[Path] = PrivateAttr(default_factory=list)

    @model_validator(mode="after")
    def _exists(self, info: ValidationInfo) -> FileEntry:
        self._resolved = resolve_paths(self.path, _base(info))
        if self.label and len(self._resolved) > 1:
            raise ValueError(f"a label names one file, but {self.path!r} matches "
                             f"{len(self._resolved)}")
        return self

    @property
    def resolved(self) -> list[Path]:
        """The files this entry names (absolute or relative to the working folder)."""
        return list(self._resolved)


File = Annotated[FileEntry, BeforeValidator(_file_entry)]


class PathRef(_Model):
    """A single existing file (scene files, references)."""

    path: str = Field(min_length=1)
    _resolved: Path | None = PrivateAttr(default=None)

    @model_validator(mode="after")
    def _exists(self, info: ValidationInfo) -> PathRef:
        if _GLOB_CHARS & set(self.path):
            raise ValueError(f"{self.path!r}: give one file here, not a pattern")
        self._resolved = resolve_paths(self.path, _base(info))[0]
        return self

    @property
    def resolved(self) -> Path:
        """The file."""
        assert self._resolved is not None
        return self._resolved


Ref = Annotated[PathRef, BeforeValidator(_file_entry)]


def _listify(v: Any) -> Any:
    return [v] if isinstance(v, (str, dict)) else v


# --------------------------------------------------------------------------- products
class Product(_Model):
    """``products.<name>``: properties of a product named in the logs.

    The name is the log's ``product`` (HPT header), or ``product-condition`` for
    one condition of it (``WFM-dry``); a plain product name covers every
    condition.
    """

    label: str = ""
    type: str = ""
    density: Density | None = Field(default=None, gt=0)


# --------------------------------------------------------------------------- data
#: pydantic constraints of each option check (:data:`torlab.instruments.plugin.CHECKS`)
_CHECK_FIELDS: dict[str, dict[str, float]] = {
    "positive": {"gt": 0}, "nonneg": {"ge": 0}, "fraction": {"gt": 0, "le": 1},
    "open_fraction": {"gt": 0, "lt": 1}, "coefficient": {"ge": 0, "lt": 10},
}


class OptionGroup(_Model):
    """A mapping of a data section that holds some of its options (``data.mtm.time_test``)."""

    def options(self) -> dict[str, Any]:
        """The options set (None left out), by option name."""
        names = type(self).option_names
        return {names[k]: v for k, v in self.model_dump().items() if v is not None}

    #: protocol key -> option name
    option_names: ClassVar[dict[str, str]] = {}


class DataSection(_Model):
    """A ``data.<name>`` section: ``files`` and the instrument's options that a protocol sets.

    Made from the instrument's declaration (:func:`section_model`); its own checks
    across keys are its module's ``check_section(values, resolve) -> derived``
    (``resolve(pattern)``: the files a path names, relative to the protocol).
    """

    files: Annotated[list[File], BeforeValidator(_listify)] = Field(min_length=1)
    _derived: dict[str, Any] = PrivateAttr(default_factory=dict)
    #: registry name of the instrument
    instrument_name: ClassVar[str] = ""
    #: protocol key -> option name (keys of the section itself)
    option_names: ClassVar[dict[str, str]] = {}

    @model_validator(mode="after")
    def _instrument_checks(self, info: ValidationInfo) -> DataSection:
        from torlab.instruments import get_instrument

        hook = getattr(get_instrument(type(self).instrument_name).impl(), "check_section", None)
        if hook is not None:
            base = _base(info)
            self._derived = dict(hook(self.model_dump(), lambda pat: resolve_paths(pat, base))
                                 or {})
        return self

    @property
    def derived(self) -> dict[str, Any]:
        """What the instrument's ``check_section`` derived (the HPT ``compliance``)."""
        return dict(self._derived)

    def options(self) -> dict[str, Any]:
        """The reduction's options this section sets, by option name: a path list as the
        files it names, a group's options (None left out) merged in."""
        out: dict[str, Any] = {}
        for key, name in type(self).option_names.items():
            v = getattr(self, key)
            if isinstance(v, list):
                v = [p for e in v for p in e.resolved] or None
            out[name] = v
        for key in type(self).model_fields:
            v = getattr(self, key)
            if isinstance(v, OptionGroup):
                out.update(v.options())
        return out

    def input_files(self) -> list[Path]:
        """Files the section reads besides its data files (reference logs, the compliance
        curve): its path options' files and those ``check_section`` derived."""
        out: list[Path] = []
        for key in type(self).option_names:
            v = getattr(self, key)
            if isinstance(v, list):
                out += [p for e in v for p in e.resolved]
        return out + list(self._derived.get("inputs", []))


def _option_field(o: Any) -> tuple[Any, Any]:
    """The pydantic field of one option (:class:`torlab.instruments.plugin.Option`)."""
    from torlab.units import KINDS

    kw = dict(_CHECK_FIELDS.get(o.check, {}))
    if o.kind in KINDS:
        t: Any = Annotated[float, _q(o.kind, o.quantity or None)]
    elif o.kind == "number":
        t = Annotated[float, _q("dimensionless", o.quantity or None)]
    elif o.kind == "choice":
        t = Literal[o.choices]
    elif o.kind == "flag":
        return bool, Field(default=bool(o.default), **kw)
    elif o.kind in ("path", "paths"):
        return Annotated[list[File], BeforeValidator(_listify)], Field(default=[], **kw)
    else:  # text, object: written as text
        t = str
    return (t if o.default is not None else t | None), Field(default=o.default, **kw)


def section_model(inst: Any) -> type[DataSection]:
    """The ``data.<name>`` section of an instrument, made from its options (those with a
    protocol key; an option's ``group`` is a mapping of the section)."""
    from pydantic import create_model

    name = inst.command.name
    fields: dict[str, Any] = {}
    keys: dict[str, str] = {}
    groups: dict[str, dict[str, Any]] = {}
    group_keys: dict[str, dict[str, str]] = {}
    for opt_name, o in inst.options.items():
        key = o.protocol_key(opt_name)
        if key is None:
            continue
        if o.group:
            groups.setdefault(o.group, {})[key] = _option_field(o)
            group_keys.setdefault(o.group, {})[key] = opt_name
        else:
            fields[key] = _option_field(o)
            keys[key] = opt_name
    for g, gfields in groups.items():
        model = create_model(f"{name.title()}{g.title().replace('_', '')}", __base__=OptionGroup,
                             __doc__=f"``data.{name}.{g}``: options of the {inst.title}.",
                             **gfields)
        model.option_names = group_keys[g]
        fields[g] = (model, model())
    model = create_model(f"{name.title()}Data", __base__=DataSection,
                         __doc__=f"``data.{name}``: {inst.title} files ({inst.files}).",
                         **fields)
    model.instrument_name = inst.name
    model.option_names = keys
    return model


def _data_model() -> type[_Model]:
    """``data:``: one section per instrument of the registry that has a command."""
    from pydantic import create_model

    from torlab.instruments import REGISTRY

    sections = {i.command.name: section_model(i) for i in REGISTRY.values()
                if i.command is not None}
    return create_model("Data", __base__=_Model,
                        __doc__="``data:``: the raw files, one section per instrument.",
                        **{k: (m | None, None) for k, m in sections.items()})


Data = _data_model()
#: the data sections, in registry order
DATA_SECTIONS: tuple[str, ...] = tuple(Data.model_fields)


# --------------------------------------------------------------------------- fits
def _law_choice() -> Any:
    from torlab.model.layers import LAWS

    return Literal[(*LAWS, "auto")]  # type: ignore[valid-type]


_LAW_CHOICE = _law_choice()


class HptLayerFit(_Model):
    """``fits.hpt_layers``: the third-body layer of every product from its HPT curves.

    Runs at one of ``amounts`` (a product without an applied amount, such as the
    dry reference, always qualifies) and at ``temperature`` are fitted
    (:func:`torlab.fit.layer.fit_layer_hpt`); with ``temperature_coefficients``
    the runs of the same amount at other temperatures give ``mu_c1_T``,
    ``mu_c2_T`` (:func:`torlab.fit.temperature.fit_temperature_coefficients`).
    The results are parameter sets named ``hpt:<product>``.  ``law`` is the layer law
    fitted (:mod:`torlab.model.layers`; default ``voce``), or ``auto``: every law, the
    one with the smallest AICc kept per product (its temperature runs then fitted with
    that law).
    """

    amounts: Annotated[list[Amount], BeforeValidator(_listify)] = Field(min_length=1)
    law: _LAW_CHOICE = "voce"  # type: ignore[valid-type]
    temperature: Temperature = 25.0
    temperature_tolerance: Annotated[float, _q("temperature_difference",
                                               "temperature_difference")] = Field(default=2.0, gt=0)
    joint: bool = False
    temperature_coefficients: bool = True
    #: a temperature coefficient the likelihood-ratio test does not resolve: fixed to 0
    #: (``test``) or kept with its uncertainty for the bands (``none``)
    selection: Literal["test", "none"] = "test"
    products: list[str] = []


class TractionLayerFit(_Model):
    """``fits.traction_layers[]``: a layer fitted to a measured traction curve.

    ``measured`` names one of the optical or MTM files; ``scene`` the contact
    (its ``boundary:`` is the initial guess).  The result is the parameter set
    ``traction:<name>``.
    """

    name: str = Field(min_length=1, pattern=r"^[A-Za-z0-9_.\-]+$")
    measured: Ref
    scene: Annotated[list[Ref], BeforeValidator(_listify)] = Field(min_length=1)


class LubricantFit(_Model):
    """``fits.lubricants[]``: a viscosity law from a viscometer log (``lubricant:<name>``)."""

    name: str = Field(min_length=1, pattern=r"^[A-Za-z0-9_.\-]+$")
    measured: Ref
    law: Literal["barus", "roelands"] = "roelands"


class Fits(_Model):
    """``fits:``: parameter identification; every result is a named parameter set."""

    hpt_layers: HptLayerFit | None = None
    traction_layers: list[TractionLayerFit] = []
    lubricants: list[LubricantFit] = []


# --------------------------------------------------------------------------- reports
Creepages = Annotated[list[float], _grid_values("dimensionless", quantity="creepage")]
Speeds = Annotated[list[float], _grid_values("velocity", positive=True, quantity="speed")]


def _speeds_or_measured(v: Any) -> Any:
    if v is None or v == "measured":
        return v
    return _grid_values("velocity", positive=True, quantity="speed").func(v)


SpeedsOrMeasured = Annotated[Any, BeforeValidator(_speeds_or_measured)]


def _check_params(v: list[str]) -> list[str]:
    for p in v:
        kind, _, name = p.partition(":")
        if kind not in ("hpt", "traction", "lubricant") or not name:
            raise ValueError(f"{p!r}: write hpt:<product>, hpt:*, traction:<name> or "
                             "lubricant:<name>")
    if sum(p == "hpt:*" for p in v) > 1:
        raise ValueError("hpt:* may appear once")
    return v


ParamSets = Annotated[list[str], AfterValidator(_check_params)]


def _listify_pair(v: Any) -> Any:
    """``[first, last]`` -> a pair (two numbers)."""
    if isinstance(v, list):
        if len(v) != 2:
            raise ValueError(f"give two values [first, last], got {len(v)}")
        return tuple(v)
    return v


def _pair(v: Any) -> Any:
    if isinstance(v, str):  # a band preset (thesis, intermediate) or LOW:HIGH
        from torlab.model.retention import retention_band

        try:
            return retention_band(v)[0]
        except TorlabInputError as e:
            raise ValueError(e.message) from None
    if isinstance(v, list):
        if len(v) != 2:
            raise ValueError(f"give two values [low, high], got {len(v)}")
        return tuple(v)
    return v


Band = Annotated[tuple[Fraction, Fraction], BeforeValidator(_pair)]


class CurveSpec(_Model):
    """One modelled (and/or measured) curve of a traction, Stribeck or film report.

    Attributes
    ----------
    label
        Legend and file-name label; ``{set}`` is replaced by the parameter-set
        name when ``params`` expands ``hpt:*``.
    scene
        Scene file(s), later files overriding earlier ones (``torlab predict``).
    params
        Fitted parameter sets applied on top of the scene, in order:
        ``hpt:<product>``, ``hpt:*`` (one curve per product), ``traction:<name>``,
        ``lubricant:<name>``.
    speeds
        Traction: rolling speeds (each a curve), overriding the scene's; or
        ``measured`` for the speeds of the measured file.
    measured
        One of the protocol's optical or MTM files, drawn as points.
    """

    label: str = Field(min_length=1)
    scene: Annotated[list[Ref], BeforeValidator(_listify)] = []
    params: ParamSets = []
    speeds: SpeedsOrMeasured = None
    measured: Ref | None = None

    @model_validator(mode="after")
    def _something(self) -> CurveSpec:
        if not self.scene and self.measured is None:
            raise ValueError("a curve needs a scene (to model) or a measured file (or both)")
        return self


class TractionReport(_Model):
    """``reports.traction``: mu against creepage, modelled and/or measured; trend (H4.1)."""

    creepage: Creepages = Field(default_factory=lambda: [i * 0.001 for i in range(51)])
    trend_tolerance: Fraction = Field(default=0.01, gt=0)
    #: probability a trend class needs to be called (else "undetermined")
    trend_probability: Fraction = Field(default=0.9, gt=0.5, lt=1)
    band: Band | None = None
    curves: list[CurveSpec] = Field(min_length=1)


class StribeckReport(_Model):
    """``reports.stribeck``: mu against rolling speed and Lambda, regimes, asperity load share."""

    speed: Speeds = Field(default_factory=lambda: [0.01 * (300.0 ** (i / 39)) for i in range(40)])
    creepage: Annotated[float, _q("dimensionless", "creepage")] | None = None
    curves: list[CurveSpec] = Field(min_length=1)


class FilmReport(_Model):
    """``reports.film``: film thickness against rolling speed, speed exponent, model."""

    min_speed: Velocity = Field(default=0.0, ge=0)
    curves: list[CurveSpec] = Field(min_length=1)


class AmountReport(_Model):
    """``reports.amount``: friction against applied amount per product (Paper C).

    Attributes
    ----------
    temperature
        Runs at this temperature (within ``temperature_tolerance``) form the
        series; default 25 degC.
    band
        Optimal friction band (default 0.15-0.25, thesis chapter 6).
    threshold
        Low-friction threshold whose crossing amount is reported (default 0.15).
    basis
        x axis of the cross-product comparison: ``mass`` (mg, volumes times the
        product density) or ``amount`` (as applied).
    curve
        ``logistic``: a four-parameter logistic curve in log amount, fitted per
        product, gives the crossing and its interval; ``interpolation``:
        log-linear interpolation between the bracketing runs (no interval).
    confidence
        Level of the crossing intervals.
    products
        Products to include (default: every product with an applied amount).
    """

    temperature: Temperature = 25.0
    temperature_tolerance: Annotated[float, _q("temperature_difference",
                                               "temperature_difference")] = Field(default=2.0, gt=0)
    band: Band = (0.15, 0.25)
    threshold: Fraction = Field(default=0.15, gt=0)
    basis: Literal["mass", "amount"] = "mass"
    curve: Literal["logistic", "interpolation"] = "logistic"
    confidence: Fraction = Field(default=0.95, gt=0, lt=1)
    #: probability a verdict (crossing within the tested amounts ...) needs to be called
    probability: Fraction = Field(default=0.9, gt=0.5, lt=1)
    products: list[str] = []

    @model_validator(mode="after")
    def _band(self) -> AmountReport:
        if not self.band[0] < self.band[1]:
            raise ValueError(f"band: the lower limit {self.band[0]:g} must be below the upper "
                             f"{self.band[1]:g}")
        return self


class InitialDrop(_Model):
    """``reports.time_test.initial_drop``: the modelled coefficient at the test's SRR.

    ``creepage`` defaults to the median SRR of each timed step after the
    application.
    """

    scene: Annotated[list[Ref], BeforeValidator(_listify)] = Field(min_length=1)
    params: ParamSets = []
    creepage: Annotated[float, _q("dimensionless", "creepage")] | None = None


class TimeTestReport(_Model):
    """``reports.time_test``: time tests after application (Paper B, thesis Fig. 5.9)."""

    band: Band = (0.15, 0.25)
    #: probability a verdict (recovered, mean after recovery in the band) needs to be called
    probability: Fraction = Field(default=0.9, gt=0.5, lt=1)
    #: block-bootstrap replicates for the intervals of the time-test figures (0: none)
    replicates: int = Field(default=200, ge=0, le=5000)
    #: repeated tests: composition -> the labels of its tests (``data.mtm.files``); their
    #: scatter widens the intervals where larger than the records' own noise
    repeats: dict[str, list[str]] = Field(default_factory=dict)
    initial_drop: InitialDrop | None = None


def _formats(v: Any) -> Any:
    """``png, svg`` or a list -> ``["png", "svg"]`` (lower case)."""
    if isinstance(v, str):
        v = v.split(",")
    return [x.strip().lower().lstrip(".") if isinstance(x, str) else x for x in v] \
        if isinstance(v, list) else v


def _retention_amount(v: Any) -> Any:
    """An applied amount for the retention model: volume, mass or per area, with its unit."""
    from torlab.model.amount import parse_amount

    if isinstance(v, bool) or not isinstance(v, (str, int, float)):
        return v
    try:
        parse_amount(v)
    except TorlabInputError as e:
        raise ValueError(e.message) from None
    return str(v)


RetentionAmount = Annotated[str, BeforeValidator(_retention_amount)]
RemovalLawName = Literal["zero_order", "first_order", "zero_order+spread", "first_order+spread"]


def _fraction_or_fit(v: Any) -> Any:
    from torlab._suggest import word_or

    return word_or(v, "fit", _q("dimensionless").func)


def _time_or_auto(v: Any) -> Any:
    from torlab._suggest import word_or

    return word_or(v, "auto", _q("time").func)


class RetentionPredictionSpec(_Model):
    """``reports.retention.prediction``: coefficient against passes on a scene.

    ``amount`` as applied (``4 uL`` with the product's density, ``4 mg``) needs
    ``band_length`` on a rail (the length it covers) or ``track_radius`` on a
    disc; or give it per area (``100000 mg/m^2``).
    """

    scene: Annotated[list[Ref], BeforeValidator(_listify)] = Field(min_length=1)
    amount: RetentionAmount
    creepage: Annotated[float, _q("dimensionless", "creepage")] = 0.01
    band: Band = (0.15, 0.25)
    band_length: Length | None = Field(default=None, gt=0)
    track_radius: Length | None = Field(default=None, gt=0)
    pass_interval: Time | None = Field(default=None, gt=0)
    passes: float | None = Field(default=None, gt=0, le=1e9)
    draws: int = Field(default=200, ge=0, le=5000)
    seed: int = 0
    #: passes (cycles of a disc) of the effective friction level and the fraction in the
    #: band, [first, last]; default the predicted range
    window: Annotated[tuple[float, float], BeforeValidator(_listify_pair)] | None = None
    #: "band" (passes until mu leaves the band) or a fraction of the dry coefficient
    retentivity: Literal["band"] | Annotated[float, Field(gt=0, le=1)] = "band"

    @model_validator(mode="after")
    def _check(self) -> RetentionPredictionSpec:
        if self.creepage == 0:
            raise ValueError("creepage must not be zero (no creepage dissipates no energy)")
        if not self.band[0] < self.band[1]:
            raise ValueError(f"band: the lower limit {self.band[0]:g} must be below the upper "
                             f"{self.band[1]:g}")
        return self


class RetentionSweepSpec(_Model):
    """``reports.retention.sweep``: a slip sweep recorded while product is removed (H4.1).

    On the prediction's scene; the time between passes is the disc track's
    revolution (``prediction.track_radius``) or ``pass_interval`` on a rail.
    """

    seconds: Annotated[float, _q("time", "duration")] = Field(gt=0)
    creepage: Creepages = Field(default_factory=lambda: [i * 0.001 for i in range(51)])
    amount: RetentionAmount | None = None
    pass_interval: Time | None = Field(default=None, gt=0)
    trend_tolerance: Fraction = Field(default=0.01, gt=0)
    #: probability a trend class or the verdict needs over the draws (else "undetermined")
    trend_probability: Fraction = Field(default=0.9, gt=0.5, lt=1)
    draws: int = Field(default=100, ge=0, le=2000)


class RetentionReport(_Model):
    """``reports.retention``: removal fit and retention prediction of one product.

    The HPT runs of ``product`` at ``temperature`` (one fit per applied amount,
    repeats of an amount fitted jointly) and the ``dry`` runs form the amount
    layer; the time tests (``time_tests``, default every ``data.mtm`` file) give
    the removal law on the ``tribometer`` scene (default the PCS MTM ball on
    disc); ``prediction`` (and ``sweep``) use both (docs/model/retention.md).
    """

    product: str = Field(min_length=1)
    dry: str = "dry"
    temperature: Temperature = 25.0
    temperature_tolerance: Annotated[float, _q("temperature_difference",
                                               "temperature_difference")] = Field(default=2.0, gt=0)
    density: Density | None = Field(default=None, gt=0)
    repeatability: Fraction = Field(default=0.0, ge=0, lt=1)
    dry_amount: RetentionAmount | None = None
    time_tests: Annotated[list[File], BeforeValidator(_listify)] = []
    tribometer: Annotated[list[Ref], BeforeValidator(_listify)] = []
    laws: list[RemovalLawName] = Field(default_factory=lambda: ["zero_order", "first_order"],
                                       min_length=1)
    law: RemovalLawName | None = None
    transfer: Annotated[Any, BeforeValidator(_fraction_or_fit)] = 1.0
    skip: Annotated[Any, BeforeValidator(_time_or_auto)] = "auto"
    axis: Literal["passes", "cycles", "time"] = "passes"
    prediction: RetentionPredictionSpec
    sweep: RetentionSweepSpec | None = None

    @model_validator(mode="after")
    def _check(self) -> RetentionReport:
        if self.transfer != "fit" and not 0 < self.transfer <= 1:
            raise ValueError(f"transfer must be in (0, 1] or 'fit', got {self.transfer:g}")
        if self.skip != "auto" and self.skip < 0:
            raise ValueError("skip must be a non-negative time or 'auto'")
        return self


class CompareSpec(_Model):
    """One entry of ``reports.compare``: items of the run compared on the quantities they
    share (:mod:`torlab.comparison`).

    The items are the run's products and compositions: a product's fitted layer and
    temperature coefficients (``fits.hpt_layers``, label: the product), its amount
    crossing (``reports.amount``), a time test's figures (``reports.time_test``, label:
    the file's label or its composition under ``repeats``), a retention prediction's
    figures (``reports.retention``, label: its product).
    """

    name: str = Field(default="", description="title of the comparison")
    items: list[str] = Field(default_factory=list,
                             description="labels of the items (default every item)")
    reference: str | None = Field(default=None, description="compare every item against it "
                                  "(default the first); none with pairs: all")
    pairs: Literal["reference", "all"] = "reference"
    quantities: list[str] = Field(default_factory=list,
                                  description="quantities to compare (default every shared)")
    better: dict[str, Literal["higher", "lower"]] = Field(default_factory=dict)
    #: probability a verdict needs to be called
    probability: Fraction = Field(default=0.9, gt=0.5, lt=1)


#: the values of ``reports.fit_figures`` (and ``torlab run --fit-figures``:
#: :func:`torlab.protocols.context.check_fit_figures`)
FitFigures = Literal["auto", "all", "warned", "none"]


class Reports(_Model):
    """``reports:``: the analyses to write (each needs its data; see docs/protocols.md)."""

    amount: AmountReport | None = None
    time_test: TimeTestReport | None = None
    traction: TractionReport | None = None
    stribeck: StribeckReport | None = None
    film: FilmReport | None = None
    retention: RetentionReport | None = None
    #: comparisons of the run's items (products, compositions): one entry or a list
    compare: Annotated[list[CompareSpec], BeforeValidator(_listify)] = []
    #: file formats of every figure (``torlab run --formats`` overrides)
    figure_formats: Annotated[list[Literal["png", "svg", "pdf"]],
                              BeforeValidator(_formats)] = Field(default=["png"], min_length=1)
    #: draw the figures at all (``torlab run --no-figures``: false); without them the
    #: reports hold every number and table, and name the figures not drawn
    figures: bool = True
    #: which fitted sets get a data-against-model figure (``torlab run --fit-figures``):
    #: ``auto``, every set when the run fits at most 24 sets, above that as ``warned``;
    #: ``all``; ``warned``, the sets whose fit warned (a parameter the data do not
    #: determine, a bound reached, a scatter beyond the model's ...); ``none``.  The
    #: parameter table and the warnings hold every set either way
    fit_figures: FitFigures = "auto"
    #: how report.html shows the figures: ``link`` (the figure files, its size the same at
    #: any campaign size) or ``embed`` (base64 inside the page: one self-contained file)
    html_figures: Literal["link", "embed"] = "link"


# --------------------------------------------------------------------------- protocol
class Protocol(_Model):
    """A whole protocol (``version: 1``)."""

    version: Literal[1]
    name: str = Field(min_length=1, pattern=r"^[A-Za-z0-9_.\-]+$")
    title: str = ""
    description: str = ""
    products: dict[str, Product] = {}
    data: Data
    fits: Fits = Fits()
    reports: Reports = Reports()

    @model_validator(mode="after")
    def _anything(self) -> Protocol:
        d = self.data
        if all(getattr(d, k) is None for k in DATA_SECTIONS) and not (
                self.reports.traction or self.reports.stribeck or self.reports.film):
            raise ValueError(f"nothing to do: give data ({', '.join(DATA_SECTIONS)}) or a "
                             "model-only report (traction, stribeck, film)")
        return self
