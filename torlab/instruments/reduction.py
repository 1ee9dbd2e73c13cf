"""The result of every reduction: :class:`Reduction`, one type for every instrument."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from torlab.errors import TorlabInputError

__all__ = ["Curve", "Reduction"]


@dataclass
class Curve:
    """A measured curve taken from a reduction (for fits and reports).

    Attributes
    ----------
    label
        What it is (``"40.2 °C"``, ``"0.025 m/s"``, ``""`` for the only one).
    x, y
        Abscissa and ordinate (SI): SRR (fraction) and coefficient for
        traction curves, rolling speed (m/s) and coefficient for Stribeck
        curves, rolling speed and film thickness (m) for film curves.
    speed_m_s
        Mean rolling speed of a traction curve (None when not logged).
    temperature_C
        Mean temperature of the curve, if logged.
    srr
        SRR of each point of a Stribeck curve (NaN where not logged).
    y_sd
        Spread (standard deviation) of each ``y`` over its averaging window, where
        the reduction has it (None otherwise): the error bars of the figures.
    """

    label: str
    x: Any
    y: Any
    speed_m_s: float | None = None
    temperature_C: float | None = None
    srr: Any = None
    y_sd: Any = None


@dataclass
class Reduction:
    """One reduced file, whatever the instrument.

    Attributes
    ----------
    instrument
        Registry name of the instrument (``"hpt"``, ``"pcs"``, ``"optical"``,
        ``"visc"``; :data:`torlab.instruments.REGISTRY`).
    source
        The file (as given).
    tables
        Name -> DataFrame, SI units in the column names.  ``torlab reduce``
        writes each as ``<file stem>_<name>.csv``.
    key_numbers
        The file's key figures (flat, SI): what :meth:`summary` reports.
    notes
        What the reduction decided or found (one sentence each).
    meta
        The parser's metadata of the file.
    detail
        The instrument's own result object (:class:`~torlab.reduce.hpt.HptResult`,
        :class:`~torlab.reduce.mtm.PcsReduction`,
        :class:`~torlab.reduce.optical.OpticalResult`,
        :class:`~torlab.reduce.viscometer.ViscometerResult`).
    optional
        Table name -> columns that may hold empty cells ("not logged").
    files
        Further outputs: name -> dict (written as JSON) or text.
    detected
        How the instrument was chosen (``"first line 'MTM311 Test Data File'"``
        or ``"--as pcs"``).
    """

    instrument: str
    source: str
    tables: dict[str, Any]
    key_numbers: dict[str, Any] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    meta: Any = None
    detail: Any = None
    optional: dict[str, tuple[str, ...]] = field(default_factory=dict)
    files: dict[str, Any] = field(default_factory=dict)
    detected: str = ""
    #: the name of the results where the file's own name is not unique among the files
    #: reduced together (a protocol names two ``export.txt`` by their labels)
    name: str = ""

    @property
    def label(self) -> str:
        """File name (or :attr:`name`)."""
        return self.name or Path(self.source).name

    @property
    def stem(self) -> str:
        """File name without its extension, or :attr:`name` (the output prefix)."""
        return self.name or Path(self.source).stem

    def table(self, name: str) -> Any:
        """The table ``name``; a clear error naming the tables there are."""
        if name not in self.tables:
            from torlab._suggest import did_you_mean

            raise TorlabInputError(f"no table {name!r} in this {self.instrument} reduction (tables: "
                                   f"{', '.join(self.tables) or 'none'}){did_you_mean(name, self.tables)}",
                                   path=self.source)
        return self.tables[name]

    def summary(self) -> dict[str, Any]:
        """Key numbers: file, instrument, how it was detected, rows per table, figures, notes.

        Non-finite numbers are None, so the dict is JSON-safe.
        """
        def clean(v: Any) -> Any:
            if hasattr(v, "item") and not isinstance(v, (list, dict, str)):
                v = v.item()
            return None if isinstance(v, float) and not math.isfinite(v) else v

        return {"file": self.label, "instrument": self.instrument, "detected": self.detected,
                "tables": {k: len(v) for k, v in self.tables.items()},
                **{k: clean(v) for k, v in self.key_numbers.items()},
                "notes": list(self.notes)}

    def figures(self) -> dict[str, Any]:
        """Name -> matplotlib figure of this file (``""`` names the file's main figure)."""
        return {k: p.draw() if hasattr(p, "draw") else p for k, p in self.plots().items()}

    def plots(self) -> dict[str, Any]:
        """Name -> the declared figure (:class:`torlab.reports.render.Plot`) of this file:
        what :meth:`figures` draws, for drawing later, in parallel or from a cache."""
        return self._impl().figures(self)

    # -- measured curves for fits and reports ---------------------------------------------
    def traction_curves(self) -> list[Curve]:
        """Traction curves mu(SRR), one per rolling speed or step, folded onto positive SRR.

        Raises
        ------
        TorlabInputError
            The file holds no traction curve.
        """
        return self._curves("traction_curves", "traction curve")

    def stribeck_curve(self) -> Curve:
        """The Stribeck curve mu(rolling speed) (one, all points sorted by speed)."""
        (c,) = self._curves("stribeck_curves", "Stribeck curve")[:1]
        return c

    def film_curves(self) -> list[Curve]:
        """Film thickness against rolling speed, one curve per film step or test."""
        return self._curves("film_curves", "film thickness")

    def _curves(self, fn: str, what: str) -> list[Curve]:
        impl = self._impl()
        out = getattr(impl, fn)(self) if hasattr(impl, fn) else []
        if not out:
            raise TorlabInputError(f"no {what} in this {self.instrument} file", path=self.source)
        return out

    def _impl(self) -> Any:
        from torlab.instruments import get_instrument

        return get_instrument(self.instrument).impl()

    def to_xlsx(self, path: str | Path) -> Path:
        """Write every table as one sheet of an Excel workbook (needs openpyxl)."""
        from torlab.outputs import write_xlsx

        return write_xlsx(path, {k: v for k, v in self.tables.items()})

    def __repr__(self) -> str:
        tabs = ", ".join(f"{k} ({len(v)} rows)" for k, v in self.tables.items())
        return f"<Reduction {self.instrument} {self.label}: {tabs}>"
