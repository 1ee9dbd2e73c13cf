"""torlab's public API: what a notebook calls, available at the top level (``torlab.reduce``).

Every function accepts quantities as unit strings (``window="20 um"``,
``creepage="0:0.05:101"``, ``speed="10 mm/s:2 m/s:50"``) or as SI numbers, and
returns DataFrames and result objects:

========================  ===============================================================
:func:`read`              a raw file -> ``(DataFrame, metadata)``, instrument detected
:func:`reduce_file`       one file -> :class:`~torlab.instruments.reduction.Reduction`
:func:`reduce_files`      files, folders, patterns -> list of Reductions
:func:`reduce_to_folder`  files, folders, patterns -> tables, figures, summaries in a folder
:func:`fit_hpt`           HPT curves -> the layer's :class:`~torlab.fit.result.FitResult`
:func:`fit_traction`      a measured traction curve and a scene -> layer FitResult
:func:`fit_temperature`   HPT runs at several temperatures -> temperature coefficients
:func:`fit_viscosity`     viscometer data -> Barus / Roelands FitResult
:func:`fit_film`          film thickness against speed -> speed exponent (and alpha)
:func:`fit_removal`       time tests after application + HPT amount series -> removal law
:func:`load_scene`        scene and parameter files -> a validated Scene
:func:`predict_traction`  scene, creepages -> traction curve (mu, trend after saturation)
:func:`predict_stribeck`  scene, speeds, creepage -> Stribeck curve (mu, film, regimes)
:func:`predict_retention` scene, removal parameters, amount -> mu against passes, band crossings
:func:`predict_sweep`     a slip sweep recorded while product is removed, beside the steady curve
:func:`predict_creep`     dry scene, creepages, lateral creepage, spin -> Fx, Fy, Mz curve
:func:`creep_table`       dry scene, creepage x lateral x spin axes -> creep-force table
:func:`fit_polach`        dry scene, creepage and speed range -> Polach's parameters
:func:`run_protocol`      a YAML protocol -> reports in a folder
:func:`compare`           products or conditions -> differences, P(A better), rankings
========================  ===============================================================

Example::

    import torlab

    red = torlab.reduce_file("exports/demo_5.txt")        # instrument detected, said in red.detected
    red.tables["timed"].head()
    fit = torlab.fit_hpt("logs/hpt_OFM1_4uL_25C.txt", compliance="logs/rig_compliance.csv")
    print(fit.report())
    curve = torlab.predict_traction("scene.yaml", "0:5 %:51", params=fit)
"""

from __future__ import annotations

import copy
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeAlias

from torlab.errors import TorlabInputError

__all__ = [
    "compare",
    "creep_table",
    "fit_film",
    "fit_hpt",
    "fit_polach",
    "fit_removal",
    "fit_temperature",
    "fit_traction",
    "fit_viscosity",
    "load_scene",
    "predict_creep",
    "predict_retention",
    "predict_stribeck",
    "predict_sweep",
    "predict_traction",
    "read",
    "reduce_file",
    "reduce_files",
    "reduce_to_folder",
    "run_protocol",
    "time_test_items",
]

PathLike = str | os.PathLike[str]

if TYPE_CHECKING:
    import pandas as pd

    from torlab.fit.result import FitResult
    from torlab.fit.retention_params import RemovalFit
    from torlab.instruments.output import ReducedFolder
    from torlab.instruments.reduction import Reduction
    from torlab.model.creep_table import CreepTable
    from torlab.model.mixed import StribeckPrediction
    from torlab.model.prediction import TractionPrediction
    from torlab.model.retention import RetentionPrediction, SweepPrediction
    from torlab.protocols.runner import RunResult
    from torlab.scene import Scene

    #: a scene as a user gives it: a scene file, a dict of its sections, or a Scene
    SceneLike: TypeAlias = PathLike | Mapping[str, Any] | Scene


# ------------------------------------------------------------------ reading and reducing
def read(path: PathLike, instrument: str | None = None, **options: Any) -> tuple[pd.DataFrame, Any]:
    """Parse a raw instrument file.

    Parameters
    ----------
    path
        The file.
    instrument
        ``"pcs"`` (or ``"mtm"``, ``"etm"``, ``"ehd2"``), ``"hpt"``, ``"optical"``,
        ``"visc"``; default: detected from the file's first lines.
    **options
        Parser options (``map=`` for an HPT CSV of another rig).

    Returns
    -------
    (pandas.DataFrame, metadata)
        The rows in SI units (the unit in each column name) and the file's header.
    """
    from torlab.instruments import read_file

    return read_file(path, instrument, **options)


def reduce_file(path: PathLike, instrument: str | None = None, **options: Any) -> Reduction:
    """Reduce one file as ``torlab reduce`` does (the name ``torlab.reduce`` is the package
    of the reductions themselves, :mod:`torlab.reduce`).

    Parameters
    ----------
    path
        The file.
    instrument
        Registry name or alias (see :func:`read`); default: detected.
    **options
        The instrument's reduction options, unit strings allowed: HPT
        ``window="20 um"``, ``compliance="0.012 um/MPa"``; PCS
        ``after_application=True``, ``duration="20 min"``; optical
        ``window="4 s"``; viscometer ``reference=[...]``, ``law="roelands"``
        (``torlab reduce --list`` names them all).

    Returns
    -------
    Reduction
        ``tables`` (name -> DataFrame), ``summary()``, ``notes``, ``figures()``
        and the measured curves (``traction_curves()`` ...).
    """
    from torlab.instruments import reduce_file as _reduce

    return _reduce(path, instrument, **options)


def reduce_files(paths: PathLike | Sequence[PathLike], instrument: str | None = None,
                 **options: Any) -> list[Reduction]:
    """Reduce files, folders and patterns (``"exports/*.txt"``), each file's instrument
    detected unless given; options as in :func:`reduce_file` (computed once for the batch)."""
    from torlab.instruments import expand_inputs, is_instrument
    from torlab.instruments import reduce_files as _reduce

    items = [paths] if isinstance(paths, (str, os.PathLike)) else list(paths)
    files, _ = expand_inputs(items, "input", is_instrument(instrument))
    return _reduce(files, instrument, **options)


def reduce_to_folder(paths: PathLike | Sequence[PathLike], out: PathLike,
                     instrument: str | None = None, *, force: bool = False, xlsx: bool = False,
                     figures: bool = True, formats: Any = None, every_file: bool = False,
                     what: str = "input", command: str | None = None, **options: Any
                     ) -> ReducedFolder:
    """Reduce files, folders and patterns and write the results into the folder ``out``, as
    ``torlab reduce`` and ``torlab <instrument> reduce`` do.

    Parameters
    ----------
    paths
        Files, folders (their files of the instrument) and patterns (``"exports/*.txt"``).
    out
        Output folder: ``<file>_<table>.csv``, figures, per instrument ``summary.csv``.
    instrument
        Registry name or alias; default: each file's detected.
    force
        Replace torlab's earlier results in ``out``.
    xlsx
        Also write ``tables.xlsx`` (every table as a sheet).
    figures, formats
        Draw the figures, in these formats (``"png,svg"``; default PNG).
    every_file
        A folder gives every data file, not only those detected as ``instrument`` (an HPT
        column map makes another rig's CSV readable).
    what
        One input in messages (``"HPT log"``).
    command
        The command line recorded in the folder's manifest.
    **options
        The instrument's options, unit strings allowed (as :func:`reduce_file`).

    Returns
    -------
    ReducedFolder
        ``reductions``, ``notes`` (what folders left out), ``written`` (file names) and
        ``tables()`` (each instrument's console tables).
    """
    from torlab.instruments.output import reduce_to_folder as _reduce

    items = [paths] if isinstance(paths, (str, os.PathLike)) else list(paths)
    return _reduce(items, out, instrument, force=force, xlsx=xlsx, figures=figures,
                   formats=formats, every_file=every_file, what=what, command=command,
                   **options)


# ------------------------------------------------------------------ fits
def fit_hpt(curves: Any, *, compliance: Any = None, sigma: Any = None,
            law: Any = None) -> FitResult:
    """The third-body layer from HPT curves (Voce: ``mu_c1, mu_c2, L_mue, L_mup``, thesis
    Eqs. 5.24-5.29); several curves (repeats of one product and amount) fitted jointly.

    Parameters
    ----------
    curves
        One or a list of: HPT logs or reduced CSVs (paths), :class:`Reduction` objects
        of HPT logs, :class:`~torlab.reduce.hpt.HptResult` or reduced DataFrames
        (:func:`torlab.instruments.measured.hpt_curves`).
    compliance
        Rig compliance: a curve file, ``"0.012 um/MPa"``, m/Pa, or a
        :class:`~torlab.reduce.hpt.RigCompliance` (default: the one the
        reduction subtracted).
    sigma
        Normal stress (``"750 MPa"`` or Pa); default: each curve's mean.
    law
        The layer law (``"voce"``, the default; ``"linear"``, ``"perfect"``; or ``"auto"``:
        each fitted, the smallest AICc kept, the comparison in ``meta["law_selection"]``;
        ``docs/model/layers.md``).

    Returns
    -------
    FitResult
    """
    from torlab.fit.layer import fit_layer_hpt
    from torlab.instruments.measured import hpt_curves
    from torlab.units import to_si

    s = None if sigma is None else to_si(sigma, "pressure", where="sigma")
    return fit_layer_hpt(hpt_curves(curves, compliance=compliance, sigma=s), law=law)


def fit_temperature(curves: Any, temperatures: Any = None, *,
                    reference_temperature: Any = "25 degC", compliance: Any = None
                    ) -> FitResult:
    """Temperature coefficients ``mu_c1_T, mu_c2_T`` (thesis Eqs. 5.26-5.27) from one layer
    fit per HPT run (paths, Reductions, HptResults or FitResults).

    ``temperatures`` (one per run, ``"50 degC"`` or degC) default to the logs' headers.
    """
    from torlab.fit.result import FitResult
    from torlab.fit.temperature import fit_temperature_coefficients
    from torlab.instruments.measured import hpt_curves
    from torlab.reduce.hpt import RigCompliance

    comp = RigCompliance.from_spec(compliance)
    items = [c if isinstance(c, FitResult) else hpt_curves(c, compliance=comp)[0]
             for c in curves]
    temps = None if temperatures is None else \
        [_si(t, "temperature", "temperatures", "temperature") + 273.15 for t in temperatures]
    tref = _si(reference_temperature, "temperature", "reference_temperature", "temperature")
    return fit_temperature_coefficients(items, temps, reference_temperature_C=tref)


def _param_file(path: PathLike) -> dict:
    """The keys of a parameter file (YAML mapping), to merge over a scene given as an object."""
    from torlab.yamlio import load_yaml

    doc = load_yaml(path)
    if not isinstance(doc.data, dict):
        raise TorlabInputError("a parameter file must be a YAML mapping (boundary: ...)",
                               path=doc.path)
    return doc.data


def _scene(scene: SceneLike, params: Any = None) -> Scene:
    """A Scene from a Scene, a dict or scene/parameter files, with fitted parameters applied."""
    from torlab.fit.result import FitResult
    from torlab.protocols.loader import deep_merge
    from torlab.scene import Scene, scene_from_dict

    extra = params if isinstance(params, (list, tuple)) else ([] if params is None else [params])
    files = [p for p in extra if isinstance(p, (str, os.PathLike))]
    if isinstance(scene, (str, os.PathLike)):
        sc = load_scene(scene, *files)
        extra = [p for p in extra if not isinstance(p, (str, os.PathLike))]
    elif isinstance(scene, Scene):
        sc = scene
    else:
        sc = scene_from_dict(dict(scene))
    # a FitResult brings what its params.yaml holds: the values and the fit: section with
    # its covariance, so a prediction from the object has the band the file gives
    sets = [p.to_yaml_dict() if isinstance(p, FitResult) else
            _param_file(p) if isinstance(p, (str, os.PathLike)) else p for p in extra]
    if not sets:
        return sc
    d = sc.model_dump(exclude_none=True)
    # every set's covariance block is kept (independent fits), as load_scene keeps them
    covs = _covariance_blocks(d)
    for s in sets:
        s = copy.deepcopy(dict(s))
        covs += _covariance_blocks(s)
        deep_merge(d, s)
    if covs:
        d.setdefault("fit", {})["covariance"] = covs if len(covs) > 1 else covs[0]
    return scene_from_dict(d)


def _covariance_blocks(d: dict) -> list:
    """The ``fit: covariance:`` blocks of a scene or parameter mapping, taken out of it."""
    fit = d.get("fit")
    if not isinstance(fit, dict) or fit.get("covariance") is None:
        return []
    c = fit.pop("covariance")
    return list(c) if isinstance(c, list) else [c]


def fit_traction(scene: SceneLike, data: Any, *, fix: dict[str, Any] | None = None,
                 dry: bool = False, method: str | None = None) -> FitResult:
    """The layer from a measured traction curve mu(creepage) through the traction model
    (thesis Eqs. 5.14-5.30; the mixed model for a lubricated scene).

    The same fit as ``torlab fit traction`` and protocols' ``fits.traction_layers``
    (:func:`torlab.fit.traction.fit_traction_test`): the points of a log at several
    rolling speeds each at its own speed, a dry test in the scene without its lubricant.

    Parameters
    ----------
    scene
        Scene file, dict or Scene of the test contact.
    data
        A file (an instrument file with a traction curve, or a CSV with
        ``creepage``/``srr``, ``mu`` and optionally ``speed_m_s``), a
        :class:`Reduction`, or ``(creepage, mu)`` (at the scene's speed).
    fix
        Parameters held fixed: ``{"L_mup": "20 um"}``.
    dry
        Ignore the scene's lubricant and roughness (a dry test; automatic for an
        optical log of test ``dry_traction``).
    method
        The boundary method (``fastsim``, ``fastsim-kalker``, ``exact``, ``auto``; None:
        the scene's ``grid: method``): :func:`torlab.fit.traction.fit_layer_traction`.

    Returns
    -------
    FitResult
        ``meta["boundary_method"]``, ``meta["theory_error_95"]``.
    """
    import numpy as np

    from torlab.fit.traction import fit_traction_test, layer_values
    from torlab.instruments.measured import TractionData, traction_data
    from torlab.instruments.reduction import Reduction

    if isinstance(data, (str, os.PathLike, Reduction)):
        points = traction_data(data)
    else:
        xi, mu = data
        points = TractionData(np.asarray(xi, dtype=float), np.asarray(mu, dtype=float), "", None)
    return fit_traction_test(_scene(scene), points, dry=dry, fixed=layer_values(fix or {}),
                             method=method)


def fit_viscosity(data: Any, law: str = "roelands", **options: Any) -> FitResult:
    """A pressure-viscosity law (Barus Eq. 5.39 or Roelands Eq. 5.38) from viscometer data.

    Parameters
    ----------
    data
        A viscometer log path or :class:`Reduction` (its falls), or ``(p, eta)``
        (pressures, viscosities; unit strings or SI).
    law
        ``"barus"`` or ``"roelands"``.
    **options
        ``eta0`` (``"65 mPa*s"``), ``fit_eta0``, ``confidence``, ``temperature_C``.

    Returns
    -------
    FitResult
        (a :class:`~torlab.fit.viscosity.ViscosityFit`).
    """
    import numpy as np

    from torlab.fit.viscosity import fit_viscosity as _fit
    from torlab.instruments.reduction import Reduction
    from torlab.units import to_si

    if isinstance(data, (str, os.PathLike)):
        data = reduce_file(data, "visc", law="")
    if isinstance(data, Reduction):
        falls = data.detail.falls
        p, eta = falls["pressure_Pa"].to_numpy(), falls["viscosity_Pa_s"].to_numpy()
        if "temperature_C" in falls:
            options.setdefault("temperature_C", float(falls["temperature_C"].mean()))
    else:
        p = np.array([to_si(x, "pressure", where="p") for x in data[0]])
        eta = np.array([to_si(x, "viscosity", where="eta") for x in data[1]])
    if options.get("eta0") is not None:
        options["eta0"] = to_si(options["eta0"], "viscosity", where="eta0")
    return _fit(p, eta, law, **options)


def fit_film(data: Any, *, curve: str | None = None, scene: SceneLike | None = None,
             min_speed: Any = None) -> FitResult:
    """The film's speed exponent (Hamrock-Dowson: 0.67, Eq. 5.32) and, with a scene, the
    effective pressure-viscosity coefficient.

    Parameters
    ----------
    data
        A file (EHD2 export, optical log, CSV), a :class:`Reduction`, or
        ``(speed, film thickness)``.
    curve
        Which film curve of a file with several (EHD2 film steps are labelled by
        temperature: ``"40.2 °C"``).
    scene
        Scene (file, dict, Scene) of the contact, for alpha.
    min_speed
        Fit only speeds at or above this (``"50 mm/s"``).

    Returns
    -------
    FitResult
    """
    from torlab.fit.film import fit_film_thickness
    from torlab.instruments.reduction import Reduction

    if isinstance(data, (str, os.PathLike)):
        from torlab.instruments.measured import film_data

        groups = film_data(Path(data))
    elif isinstance(data, Reduction):
        groups = [(c.label, c.x, c.y) for c in data.film_curves()]
    else:
        groups = [("", data[0], data[1])]
    if curve is not None:
        groups = [g for g in groups if g[0] == curve]
    if len(groups) != 1:
        raise TorlabInputError(f"{'no' if not groups else 'several'} film curves; choose one with "
                               f"curve= (have: {', '.join(repr(g[0]) for g in groups) or 'none'})",
                               key="curve")
    vmin = _si(min_speed, "velocity", "min_speed", "speed")
    sc = None if scene is None else _scene(scene)
    return fit_film_thickness(groups[0][1], groups[0][2], scene=sc, min_speed=vmin)


# ------------------------------------------------------------------ scenes and predictions
def load_scene(scene: PathLike, *params: PathLike) -> Scene:
    """A validated scene from its YAML file and optional parameter files merged in order
    (``torlab fit`` output ``params.yaml``); all quantities in SI units."""
    from torlab.scene import load_scene as _load

    return _load(scene, *params)


def _grid(values: Any, kind: str, name: str) -> Any:
    import numpy as np

    from torlab.grids import parse_values
    from torlab.units import to_si

    if isinstance(values, str):
        return parse_values(values, kind, name)
    arr = values if isinstance(values, (list, tuple)) else np.atleast_1d(values)
    return np.array([to_si(v, kind, where=name) for v in arr], dtype=float)


def predict_traction(scene: SceneLike, creepage: Any, *, params: Any = None,
                     trend_tolerance: float = 0.01, method: str | None = None) -> TractionPrediction:
    """Traction curve of a scene (thesis model: Hertz + FASTSIM with the layer, contact
    temperature, EHL film and asperity load sharing where the scene has them).

    Parameters
    ----------
    scene
        Scene file, dict or Scene.
    creepage
        ``"0:0.05:101"`` (start:stop:count), ``"0.1 %, 1 %"``, or numbers (fractions).
    params
        Parameter files or FitResults applied over the scene (``fit_hpt(...)``).
    trend_tolerance
        Relative change after saturation below which the trend is neutral.
    method
        The boundary method: ``fastsim`` (FASTSIM corrected by Kalker's exact theory),
        ``fastsim-kalker`` (the thesis's FASTSIM), ``exact`` (Kalker's exact theory) or
        ``auto``; None: the scene's ``grid: method`` (``fastsim``).

    Returns
    -------
    TractionPrediction
        ``table`` (creepage, mu, mu_theory_error_95 ...), ``trend``, ``modelled``,
        ``summary`` (with ``method`` and ``theory_error``).
    """
    from torlab.model.predict import predict_traction as _predict

    return _predict(_scene(scene, params), _grid(creepage, "dimensionless", "creepage"),
                    trend_tolerance=trend_tolerance, method=method)


def predict_stribeck(scene: SceneLike, speed: Any, creepage: Any, *, params: Any = None
                     ) -> StribeckPrediction:
    """Stribeck curve: mu against rolling speed at one creepage, with film thickness,
    film parameter, asperity load share and regime (thesis Eq. 5.47).

    ``speed``: ``"10 mm/s:2 m/s:50"`` or numbers [m/s]; ``creepage``: ``"2 %"`` or a
    fraction; ``params`` as in :func:`predict_traction`.
    """
    from torlab.model.predict import predict_stribeck as _predict
    from torlab.units import to_si

    return _predict(_scene(scene, params), _grid(speed, "velocity", "speed"),
                    to_si(creepage, "dimensionless", where="creepage"))


# ------------------------------------------------------------------ retention
def _si(value: Any, kind: str, name: str, quantity: str | None = None) -> float | None:
    """A user quantity (string with unit, or SI number) -> SI float, range-checked; None stays."""
    from torlab.units import check_range, to_si

    if value is None:
        return None
    x = to_si(value, kind, where=name)
    return x if quantity is None else check_range(quantity, x, where=name)


def _word_or_si(value: Any, word: str, kind: str, name: str) -> Any:
    """``word`` itself, or a quantity (:func:`_si`); a misspelt word gets "did you mean"."""
    from torlab._suggest import word_or

    return word_or(value, word, lambda v: _si(v, kind, name),
                   lambda m: TorlabInputError(m, key=name))


def fit_removal(tests: Any, layer: Any, *, scene: SceneLike | None = None, density: Any = None,
                amount: Any = None, track_radius: Any = None, application_time: Any = None,
                step: int | None = None, compliance: Any = None, repeatability: float = 0.0,
                dry_amount: Any = None, temperature: Any = None,
                laws: Sequence[str] = ("zero_order", "first_order"), law: str | None = None,
                transfer: Any = 1.0, skip: Any = "auto", duration: Any = None,
                above: str = "error") -> RemovalFit:
    """A product's removal law from time tests after application (Paper B) and its HPT amount
    series (Paper C); ``docs/model/retention.md``.

    Parameters
    ----------
    tests
        Time tests: PCS exports (their timed step), ``*_timed.csv`` of
        ``torlab mtm reduce``, or :class:`~torlab.reduce.time_test.TimeTest` objects.
    layer
        The product's amount dependency: an :class:`~torlab.model.amount.AmountLayer`,
        or HPT logs / HPT layer parameter files / FitResults, one per applied
        amount plus the dry run (:func:`torlab.fit.amount.amount_layer`).
    scene
        The tribometer's contact (file, dict or Scene); default the PCS MTM ball
        on disc (19.05 mm steel ball on a steel disc).  Each test's load and
        speed replace the scene's.
    density
        Product density (``"930 kg/m^3"``) for amounts in volume; default the
        HPT logs' ``product_density``.
    amount, track_radius, application_time, step
        For the time tests: the applied amount (``"2 uL"``; default the PCS
        step's ``Applied amount``), the disc track radius, the application
        moment (default detected as the largest drop), the PCS step.
    compliance, repeatability, dry_amount, temperature
        For the layer from HPT inputs (the compliance subtracted from raw logs,
        :func:`torlab.instruments.measured.layer_inputs`; the others
        :func:`torlab.fit.amount.amount_layer`).
    laws, law, transfer, skip, duration
        As :func:`torlab.fit.removal.fit_removal` (``skip``/``duration`` as times,
        ``transfer`` a fraction or ``"fit"``).
    above
        Above the largest tested amount: ``"error"`` (default) or ``"hold"`` the
        layer of the largest (for a layer from HPT inputs; an ``AmountLayer``
        given keeps its own).

    Returns
    -------
    RemovalFit
        A :class:`~torlab.fit.result.FitResult` (``kind="removal"``);
        ``to_params(path)`` writes the parameter file ``predict_retention`` reads.
    """
    from torlab.fit.amount import amount_layer
    from torlab.fit.removal import check_options, default_tribometer_scene
    from torlab.fit.removal import fit_removal as _fit
    from torlab.instruments.measured import layer_inputs
    from torlab.model.amount import AmountLayer
    from torlab.reduce.time_test import TimeTest, read_time_test

    # the options first: a misspelt word or unit is named before the layer's HPT fits run
    sk = _word_or_si(skip, "auto", "time", "skip")
    tr = _word_or_si(transfer, "fit", "dimensionless", "transfer")
    check_options(laws, law, tr)
    t_app = _si(application_time, "time", "application_time")
    radius = _si(track_radius, "length", "track_radius")
    dur = _si(duration, "time", "duration")
    dens = _si(density, "density", "density", "density")
    if isinstance(layer, AmountLayer):
        lay = layer
    else:
        items = layer if isinstance(layer, (list, tuple)) else [layer]
        lay, series, _, _ = amount_layer(
            layer_inputs(items, compliance=compliance), density=dens, dry_amount=dry_amount,
            repeatability=repeatability, above=above,
            temperature=_si(temperature, "temperature", "temperature"))
        if dens is None:  # the density the HPT runs state, for the time tests' volumes
            ds = {float(f.meta["product_density"]) for f in series
                  if isinstance(f.meta.get("product_density"), (int, float))}
            dens = ds.pop() if len(ds) == 1 else None
    items = tests if isinstance(tests, (list, tuple)) else [tests]
    tt = [t if isinstance(t, TimeTest) else read_time_test(
        t, step=step, amount=amount, density=dens, application_time=t_app,
        track_radius=radius) for t in items]
    sc = default_tribometer_scene() if scene is None else _scene(scene)
    res = _fit(tt, lay, sc, laws=laws, law=law, transfer=tr, skip=sk, duration=dur)
    if scene is None:
        res.meta["notes"] = [*res.meta.get("notes", []), "tribometer: the default PCS MTM ball "
                             "on disc (19.05 mm steel ball on a steel disc)"]
    return res


def _retention_inputs(scene: SceneLike, params: Any) -> tuple[Any, Any]:
    """The scene (overlays applied) and the one set of retention parameters among ``params``."""
    from torlab.fit.retention_params import (
        RemovalFit,
        RetentionParams,
        is_retention_file,
        load_retention,
        retention_from_dict,
    )

    items = params if isinstance(params, (list, tuple)) else [params]
    found, overlays = [], []
    for p in items:
        if isinstance(p, RetentionParams):
            found.append(p)
        elif isinstance(p, RemovalFit):
            found.append(retention_from_dict(p.parameter_file, path=str(p.meta.get("source", ""))))
        elif isinstance(p, (str, os.PathLike)) and Path(p).suffix.lower() in (".yaml", ".yml") \
                and is_retention_file(p):
            found.append(load_retention(p))
        elif p is not None:
            overlays.append(p)
    if len(found) != 1:
        raise TorlabInputError("give one removal parameter file ('torlab fit removal' output: "
                               f"params.yaml with a retention: section); got {len(found)}",
                               key="params")
    return _scene(scene, overlays or None), found[0]


def _layer_above(layer: Any, above: str | None) -> Any:
    """The amount layer with ``above`` (``"error"`` or ``"hold"``; None: as it is)."""
    if above is None or above == layer.above:
        return layer
    if above not in ("error", "hold"):
        raise TorlabInputError(f"above must be 'error' or 'hold', got {above!r}", key="above")
    layer = copy.copy(layer)
    layer.above = above
    return layer


def _band(band: Any) -> tuple[float, float]:
    """A coefficient band: a preset name (``"thesis"``, ``"intermediate"``:
    :data:`torlab.model.retention.BAND_PRESETS`), ``"LOW:HIGH"`` or ``(low, high)``."""
    from torlab.model.retention import BAND_PRESETS

    if isinstance(band, str) and ":" not in band:
        from torlab.model.retention import retention_band

        return retention_band(band)[0]
    if isinstance(band, str):
        parts = band.split(":")
        if len(parts) != 2:
            raise TorlabInputError(f"{band!r}: write LOW:HIGH (e.g. 0.15:0.25) or a preset "
                                   f"({', '.join(BAND_PRESETS)})", key="band")
        band = parts
    lo, hi = (_si(v, "dimensionless", "band") for v in band)
    return float(lo), float(hi)


def _window(window: Any) -> tuple[float, float] | None:
    """``"FIRST:LAST"`` passes (or a pair) of the effective friction level; None: all."""
    if window is None:
        return None
    if isinstance(window, str):
        parts = window.split(":")
        if len(parts) != 2:
            raise TorlabInputError(f"{window!r}: write FIRST:LAST passes, e.g. 0:5000",
                                   key="window")
        window = parts
    a, b = (_si(v, "dimensionless", "window") for v in window)
    return float(a), float(b)


def predict_retention(scene: SceneLike, params: Any, amount: Any, *, creepage: Any = "1 %",
                      passes: Any = None, time: Any = None, speed: Any = None,
                      band: Any = (0.15, 0.25), band_length: Any = None,
                      track_radius: Any = None, pass_interval: Any = None, density: Any = None,
                      transfer: Any = None, n_draws: int = 200, seed: int = 0,
                      points: int = 501, above: str | None = None, window: Any = None,
                      retentivity: Any = "band") -> RetentionPrediction:
    """The coefficient against axle passes after one application, with 95 % intervals, the
    passes until it enters and leaves the band, and the figures labs report: the effective
    friction level, the retentivity and the fraction of passes in the band
    (``docs/model/retention.md``).

    Parameters
    ----------
    scene
        Scene file, dict or Scene: the wheel-rail contact (Tab. 5.4) or a disc.
    params
        The removal parameter file (``torlab fit removal`` output), a
        :class:`~torlab.fit.removal.RemovalFit` or
        :class:`~torlab.fit.removal.RetentionParams`; or a list of it and scene
        parameter files applied over the scene.
    amount
        Applied amount: ``"4 uL"`` (with a density), ``"4 mg"``, or per area
        ``"100000 mg/m^2"``.
    creepage
        Creepage of the passes (``"1 %"`` or a fraction).
    passes, time, speed
        How far: ``passes`` (a number of passes, or a sequence of them), or
        ``time`` (``"2 h"``) at ``speed`` (default the scene's); default until
        1.2 x the passes to the dry anchor.
    band
        ``(low, high)``, ``"0.15:0.25"`` or a preset name (``"thesis"`` 0.15-0.25,
        ``"intermediate"`` 0.20-0.35: :data:`torlab.model.retention.BAND_PRESETS`, with
        where their numbers come from).
    window
        ``"FIRST:LAST"`` passes (or cycles of a disc) of the effective friction level and
        the fraction in the band; default the predicted range.
    retentivity
        ``"band"`` (passes until mu leaves the band) or a fraction of the dry coefficient
        (``0.9``: passes until mu returns to 90 % of dry).
    band_length, track_radius, pass_interval
        Rail length a volume or mass covers; a disc track's radius (then a pass
        is a revolution); time between passes on a rail (for a time axis).
    density, transfer
        Product density (default the removal fit's) and transferred fraction
        (default the fit's).
    n_draws, seed, points
        Parameter draws for the intervals, their seed, table rows.
    above
        Above the largest tested amount of the HPT series: ``"error"`` or ``"hold"``
        the layer of the largest; default the parameter file's (``"error"``).

    Returns
    -------
    RetentionPrediction
        ``table`` (``passes``, ``amount_mg_m2``, ``mu``, ``mu_low95``,
        ``mu_high95``, ``energy_J_m2`` [, ``time_s``]), ``summary``, ``modelled``.
    """
    import numpy as np

    from torlab.model.retention import predict_retention as _predict

    sc, rp = _retention_inputs(scene, params)
    layer = _layer_above(rp.layer, above)
    v = _si(speed, "velocity", "speed", "speed")
    if v is not None:
        sc = sc.model_copy(update={"kinematics": sc.kinematics.model_copy(update={"speed": v})})
    xi = _si(creepage, "dimensionless", "creepage", "creepage")
    r = _si(track_radius, "length", "track_radius", "track_radius")
    dt = _si(pass_interval, "time", "pass_interval", "duration")
    dens = _si(density, "density", "density", "density")
    t_end = _si(time, "time", "time", "duration")
    kw: dict[str, Any] = {}
    if passes is not None and t_end is not None:
        raise TorlabInputError("give passes or time, not both", key="passes")
    if t_end is not None:
        if r is None and dt is None:
            raise TorlabInputError("a time axis on a rail needs the time between axle passes "
                                   "(pass_interval=); on a disc give track_radius=", key="time")
        per = dt if dt is not None else 2 * np.pi * r / sc.kinematics.speed
        kw["n_passes"] = t_end / per
    elif passes is not None:
        if np.ndim(passes) == 0:
            kw["n_passes"] = float(passes)
            if not (np.isfinite(kw["n_passes"]) and kw["n_passes"] > 0):
                raise TorlabInputError(f"passes must be a positive number, got {passes}",
                                       key="passes")
        else:
            kw["passes"] = np.asarray(passes, dtype=float)
    pred = _predict(sc, layer, rp.removal, amount, creepage=xi, track_radius=r,
                    band_length=_si(band_length, "length", "band_length"),
                    density=dens if dens is not None else rp.density,
                    transfer=_si(transfer, "dimensionless", "transfer"), band=_band(band),
                    n_draws=int(n_draws), seed=int(seed), points=int(points),
                    pass_interval=dt, window=_window(window),
                    retentivity=retentivity if retentivity in (None, "band")
                    else _si(retentivity, "dimensionless", "retentivity"), **kw)
    pred.summary["parameter_file"] = rp.source
    pred.summary["density_kg_m3"] = dens if dens is not None else rp.density
    return pred


def predict_sweep(scene: SceneLike, params: Any, amount: Any, *, seconds: Any,
                  creepage: Any = "0:0.05:101", band_length: Any = None, track_radius: Any = None,
                  pass_interval: Any = None, density: Any = None, transfer: Any = None,
                  n_draws: int = 100, seed: int = 0, trend_tolerance: float = 0.01,
                  above: str | None = None) -> SweepPrediction:
    """A traction curve recorded during a slip sweep of ``seconds`` while the product is
    removed, beside the steady curve at the applied amount (thesis H4.1); the verdict says
    whether removal turns the curve positive, with its probability over parameter draws.

    ``creepage``: ``"start:stop:count"`` (the ramp and the points recorded);
    ``seconds``: ``"60 s"`` or s; the time between passes of a band point is a disc track's
    revolution (``track_radius``) or ``pass_interval`` on a rail; other parameters (and
    ``above``) as :func:`predict_retention`.  Returns a :class:`~torlab.model.retention.SweepPrediction`.
    """
    from torlab.model.retention import simulate_sweep

    sc, rp = _retention_inputs(scene, params)
    xi = _grid(creepage, "dimensionless", "creepage")
    if xi.size < 3 or xi[0] < 0 or not (xi[-1] > xi[0]):
        raise TorlabInputError("a sweep needs a rising creepage range start:stop:count with "
                               "start >= 0 and at least 3 points", key="creepage")
    dens = _si(density, "density", "density", "density")
    sw = simulate_sweep(sc, _layer_above(rp.layer, above), rp.removal, amount,
                        creepage=(float(xi[0]), float(xi[-1])),
                        seconds=_si(seconds, "time", "sweep", "duration"),
                        track_radius=_si(track_radius, "length", "track_radius", "track_radius"),
                        pass_interval=_si(pass_interval, "time", "pass_interval", "duration"),
                        band_length=_si(band_length, "length", "band_length"),
                        density=dens if dens is not None else rp.density,
                        transfer=_si(transfer, "dimensionless", "transfer"), points=int(xi.size),
                        n_draws=int(n_draws), seed=int(seed), trend_tolerance=trend_tolerance)
    sw.summary["parameter_file"] = rp.source
    return sw


# ------------------------------------------------------------------ creep forces (vehicle dynamics)
def predict_creep(scene: SceneLike, creepage: Any, lateral: Any = 0.0, spin: Any = 0.0, *,
                  params: Any = None, method: str | None = None) -> TractionPrediction:
    """Creep forces ``Fx, Fy, Mz`` of a dry scene along a creepage curve at one lateral
    creepage and one spin: FASTSIM with the third-body layer in all three creepages
    (Kalker's flexibilities from C11, C22, C23; the Voce limit, Eqs. 5.24-5.29; the contact
    temperature where the scene has ``thermal:``).

    Parameters
    ----------
    scene
        Scene file, dict or Scene of a dry contact (``boundary:``, no ``lubricant:``).
    creepage
        Longitudinal creepages: ``"0:2 %:41"`` (start:stop:count), ``"0.1 %, 1 %"`` or
        fractions.
    lateral
        Lateral creepage of every point: ``"0.1 %"`` or a fraction.
    spin
        Spin of every point: ``"0.5 1/m"`` or 1/m.
    params
        Parameter files or FitResults applied over the scene.
    method
        The boundary method (as :func:`predict_traction`).

    Returns
    -------
    TractionPrediction
        ``table`` (``creepage, mu, lateral, spin_1_m, mu_x, mu_y, Fx_N, Fy_N, Mz_Nm,
        adhesion_fraction``, their theory errors ``Fx_theory_error_95_N`` ...;
        ``max_temperature_C`` with ``thermal:``), ``trend``, ``modelled``, ``summary``.
    """
    from torlab.model.predict import predict_creep as _predict

    return _predict(_scene(scene, params), _grid(creepage, "dimensionless", "creepage"),
                    _si(lateral, "dimensionless", "lateral", "creepage"),
                    _si(spin, "inverse_length", "spin", "spin"), method=method)


def _amount(value: Any) -> tuple[float, str]:
    """``"4 uL"`` -> ``(4.0, "uL")``; a number -> ``(value, "")``."""
    import re

    if isinstance(value, str):
        m = re.fullmatch(r"\s*([+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?)\s*(.*?)\s*", value)
        if not m:
            raise TorlabInputError(f"{value!r}: give an amount as a number with an optional unit, "
                                   f"e.g. '4 uL'", key="amounts")
        return float(m.group(1)), m.group(2)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise TorlabInputError(f"{value!r}: give an amount as a number or '4 uL'", key="amounts")
    return float(value), ""


def creep_table(scene: SceneLike, creepage: Any, lateral: Any, spin: Any, *, speed: Any = None,
                params: Any = None, amounts: Any = None, normalised: bool = False,
                map_fn: Any = None, load: Any = None, method: str | None = None) -> CreepTable:
    """Creep-force table of a dry scene over creepage x lateral x spin (x speed x amount),
    in SI units and Kalker's normalised form, for vehicle-dynamics codes
    (``torlab predict table``).

    Parameters
    ----------
    scene
        Scene file, dict or Scene of a dry contact.
    creepage, lateral
        Axes of longitudinal and lateral creepage: ``"-1 %:1 %:21"``, a list, fractions;
        two points at least, increasing.
    spin
        Spin axis: ``"-2:2:11"`` [1/m], ``"-2 1/m, 0 1/m, 2 1/m"`` or numbers.
    speed
        Optional speed axis (``"5 m/s, 20 m/s"``): it changes the contact temperature.
    params
        Parameter files or FitResults applied over the scene.
    amounts
        Optional amount axis: ``(amount, params)`` pairs or a mapping, one parameter set
        (file, FitResult or dict) per applied amount, the amount a number or ``"4 uL"``
        (one unit for all).
    normalised
        The creepage axes are Kalker's ``xi*, eta*, phi*`` rather than fractions and 1/m.
    map_fn
        ``map``-like callable for the chunks of the table (an executor's ``map``).
    load
        Optional normal-load axis (``"10 kN, 20 kN, 80 kN"`` or N): one contact per load.
    method
        The boundary method (as :func:`predict_traction`; ``auto`` uses the exact
        solver for a table, which has no band).

    Returns
    -------
    CreepTable
        ``dataset`` (an :class:`xarray.Dataset`), ``to_long()``, ``write(out)``, ``notes``.
    """
    from torlab.model.creep_table import scene_creep_table

    kinds = ("dimensionless",) * 3 if normalised else ("dimensionless", "dimensionless",
                                                        "inverse_length")
    axes = [_grid(v, k, n) for v, k, n in zip((creepage, lateral, spin), kinds,
                                               ("creepage", "lateral", "spin"), strict=True)]
    v = None if speed is None else _grid(speed, "velocity", "speed")
    sc = _scene(scene, params)
    pairs, unit = None, ""
    if amounts is not None:
        items = list(amounts.items()) if isinstance(amounts, dict) else list(amounts)
        parsed = [(_amount(a), p) for a, p in items]
        units = {u for (_, u), _ in parsed}
        if len(units) > 1:
            raise TorlabInputError(f"amounts in different units {sorted(units)}: use one unit",
                                   key="amounts")
        unit = units.pop() if units else ""
        base = [params] if params is not None and not isinstance(params, (list, tuple)) \
            else list(params or [])
        pairs = [(a, _scene(scene, [*base, p])) for (a, _), p in parsed]
    return scene_creep_table(sc, *axes, speed=v, amounts=pairs, amount_unit=unit,
                             normalised=normalised, map_fn=map_fn,
                             provenance={"command": "torlab.creep_table"},
                             loads=None if load is None else _grid(load, "force", "load"),
                             method=method)


def fit_polach(scene: SceneLike, creepage: Any = "0:0.05:41", speed: Any = "5 m/s, 20 m/s", *,
               lateral: Any = None, spin: Any = None, params: Any = None,
               draws: int | None = None, seed: int = 0, method: str | None = None) -> FitResult:
    """Polach's creep-force parameters ``mu0, A, B, kA, kS`` (Polach 2005; spin of 1999)
    fitted to torlab's creep forces of a dry scene over a creepage and speed range
    (``torlab fit polach``).

    Parameters
    ----------
    scene
        Scene file, dict or Scene of a dry contact, with the product's layer.
    creepage
        Longitudinal creepages of the fit range (three at least): ``"0:5 %:41"``.
    speed
        Rolling speeds of the fit range: ``"5 m/s, 20 m/s"`` or m/s.
    lateral, spin
        Optional lateral creepages and spins [1/m] added at each creepage and speed.
    params
        Parameter files or FitResults applied over the scene (the product's fit).
    draws
        Layer draws from the fit's covariance, Polach refitted to each (default
        :data:`torlab.fit.polach.N_DRAWS`; 0: the layer's uncertainty is not carried).
    seed
        Seed of the draws.
    method
        The boundary method of torlab's forces (as :func:`predict_traction`).

    Returns
    -------
    FitResult
        ``params``, ``stderr``, ``data`` (torlab, Polach and their difference per point),
        ``meta`` (RMS and largest difference; ``layer_uncertainty``: the 95 % intervals
        from the layer's draws, :func:`torlab.fit.polach.layer_uncertainty`), ``warnings``.
    """
    from torlab.fit.polach import N_DRAWS, fit_polach_scene

    sc = _scene(scene, params)
    return fit_polach_scene(sc, _grid(creepage, "dimensionless", "creepage"),
                            _grid(speed, "velocity", "speed"),
                            lateral=None if lateral is None else _grid(lateral, "dimensionless",
                                                                       "lateral"),
                            spin=None if spin is None else _grid(spin, "inverse_length", "spin"),
                            draws=N_DRAWS if draws is None else draws, seed=seed,
                            source=sc.name or "scene", method=method)


def run_protocol(protocol: PathLike, out: PathLike, *, force: bool = False,
                 cache: bool = True) -> RunResult:
    """Run a YAML test protocol from raw logs to reports (``torlab run``); returns the
    :class:`~torlab.protocols.runner.RunResult` (key numbers in ``summary``)."""
    from torlab.protocols.runner import run_protocol as _run

    return _run(protocol, out, force=force, cache=cache, command="torlab.run_protocol")


def _is_time_test_file(path: Path) -> bool:
    """A PCS export or a ``*_timed.csv`` (not a parameter file, summary or folder)."""
    from torlab.instruments.measured import is_time_test_input

    return path.is_file() and path.suffix.lower() not in (".yaml", ".yml", ".json") \
        and is_time_test_input(path)


def time_test_items(source: Any, label: str | None = None, *,
                    band: tuple[float, float] = (0.15, 0.25), replicates: int = 200,
                    seed: int = 0, **options: Any) -> list[Any]:
    """Comparison items of MTM time tests after application: each test's minimum, time to
    recover, mean after recovery and time below the threshold, with the intervals of its
    record (:func:`torlab.reduce.time_test_uncertainty.time_test_uncertainty`), as a
    protocol's ``reports.compare`` has them.

    Parameters
    ----------
    source
        A PCS export, its :class:`Reduction`, or the ``*_timed.csv`` of ``torlab mtm
        reduce`` (:func:`torlab.instruments.measured.time_test_records`).
    label
        The item's name (default the file's stem, with the step when it holds several
        time tests).  Tests under one label are repeats of one item.
    band, replicates, seed
        The optimal band of the "in band" verdict, the block bootstrap's replicates and
        seed.
    options
        The time-test options of ``torlab mtm reduce`` (``threshold``, ``smooth``,
        ``tail``, ``duration`` ...; quantities with units or SI numbers).

    Returns
    -------
    list of :class:`torlab.comparison.Item`
    """
    from torlab.comparison import items_from_time_tests
    from torlab.instruments.measured import time_test_records
    from torlab.instruments.reduction import Reduction
    from torlab.reduce.time_test_uncertainty import time_test_uncertainty

    opts = _time_test_options(options)
    recs = time_test_records(source, **opts)
    src = source.source if isinstance(source, Reduction) else os.fspath(source)
    stem = Path(src).stem
    keep = {k: v for k, v in opts.items() if k not in ("family", "after_application",
                                                       "application_time")}
    evidence, results, labels = {}, {}, {}
    for r in recs:
        key = (stem, r.step)
        results[key] = r.result
        labels[key] = label or (stem if len(recs) == 1 else f"{stem} step {r.step}")
        evidence[key] = time_test_uncertainty(r.t, r.mu, r.result, keep, band=tuple(band),
                                              replicates=replicates, seed=seed)
    return items_from_time_tests(evidence, results, labels)


def _time_test_options(options: dict[str, Any]) -> dict[str, Any]:
    """The pcs instrument's time-test options, checked and in SI (``"20 min"`` -> 1200)."""
    from torlab.instruments import convert_options

    return {k: v for k, v in convert_options("pcs", options).items() if v is not None}


# ------------------------------------------------------------------ is A better than B?
def compare(items: Any, *, reference: str | None = None, quantities: Any = None,
            better: dict[str, str] | None = None, pairs: str = "reference",
            probability: float = 0.9, confidence: float = 0.95, seed: int = 0,
            time_tests: dict[str, Any] | None = None) -> Any:
    """Compare products, compositions or conditions on every quantity they share: the
    difference (a ratio for positive quantities) with its interval, P(A higher) and, with a
    stated direction, P(A better), and with more than two items a ranking with
    probabilities (:mod:`torlab.comparison`, ``docs/uncertainty.md``).

    Parameters
    ----------
    items
        ``{label: thing or [things]}`` or a list of things (or ``(label, thing)`` pairs).
        A thing is a :class:`~torlab.fit.result.FitResult`, a parameter file
        (``params.yaml``), a results folder (``torlab fit``, ``torlab predict retention``,
        ``torlab run``), an MTM time test (a PCS export, its :class:`Reduction` or the
        ``*_timed.csv`` of ``torlab mtm reduce``: :func:`time_test_items`) or a
        :class:`~torlab.comparison.Item`.  Things under one label are repeats: pooled
        with random effects before the comparison.
    reference
        The label the others are compared against (default the first).
    quantities
        Quantity names to compare (default every shared one).
    better
        ``{quantity: "higher" | "lower"}``: the direction that is better.
    pairs
        ``"reference"`` or ``"all"``.
    probability, confidence, seed
        Probability a verdict needs, the intervals' confidence, the rankings' seed.
    time_tests
        Options of the time tests read here (:func:`time_test_items`: the
        ``torlab mtm reduce`` options such as ``threshold``, ``duration``, and ``band``,
        ``replicates``).

    Returns
    -------
    CompareResult
        ``table()`` (one row per comparison), ``values_table()``, ``ranking_table()``,
        ``summary()``.
    """
    from torlab.comparison import Item, item_from_fit, items_from_path
    from torlab.comparison import compare as _compare
    from torlab.fit.result import FitResult
    from torlab.instruments.reduction import Reduction

    def load(thing: Any, label: str | None) -> list[Any]:
        if isinstance(thing, Item):
            return [thing if label is None else Item(label, thing.estimates, thing.sources,
                                                      thing.notes)]
        if isinstance(thing, FitResult):
            return [item_from_fit(thing, label)]
        if isinstance(thing, Reduction) or (isinstance(thing, (str, os.PathLike))
                                            and _is_time_test_file(Path(thing))):
            return time_test_items(thing, label, **(time_tests or {}))
        if isinstance(thing, (str, os.PathLike)):
            return items_from_path(thing, label)
        raise TorlabInputError(f"cannot compare a {type(thing).__name__}: give fit results, "
                               "parameter files, results folders or time tests", key="items")

    found: list[Any] = []
    if isinstance(items, dict):
        for lab, things in items.items():
            for t in things if isinstance(things, (list, tuple)) else [things]:
                found += load(t, str(lab))
    else:
        for t in items:
            if isinstance(t, tuple) and len(t) == 2 and isinstance(t[0], str):
                found += load(t[1], t[0])
            else:
                found += load(t, None)
    qs = [quantities] if isinstance(quantities, str) else quantities
    return _compare(found, reference=reference, quantities=list(qs) if qs else None,
                    better=better, pairs=pairs, probability=probability,
                    confidence=confidence, seed=seed)
