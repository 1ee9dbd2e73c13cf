"""Figures of a fit: data against model, and the residuals (``torlab fit``)."""

from __future__ import annotations

from collections.abc import Callable, Hashable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["KIND_TITLES", "fit_figure", "redraw_result_figure", "result_figure"]

#: per kind: (x column, x label, x factor, y measured, y model, y label, y factor, residual, log-log)
_LAYOUT: dict[str, tuple[str, str, float, str, str, str, float, str, bool]] = {
    "layer_hpt": ("displacement_m", "layer displacement u (µm)", 1e6, "shear_stress_measured_Pa",
                  "shear_stress_model_Pa", "shear stress τ (MPa)", 1e-6, "residual_Pa", False),
    "layer_traction": ("creepage", "creepage ξ = SRR (%)", 100.0, "mu_measured", "mu_model",
                       "traction coefficient μ (–)", 1.0, "residual", False),
    # temperature: the layer law's last limit with a temperature coefficient (Voce: mu_c2);
    # the others are drawn beside it (:func:`_temperature_layout`)
    "temperature": ("temperature_C", "temperature T (°C)", 1.0, "", "", "", 1.0, "", False),
    "film": ("speed_m_s", "rolling speed v (m/s)", 1.0, "film_thickness_measured_m",
             "film_thickness_model_m", "central film thickness h (nm)", 1e9, "residual_m", True),
    "film_temperature": ("temperature_C", "temperature T (°C)", 1.0, "film_thickness_measured_m",
                         "film_thickness_model_m", "film thickness h(v_ref) (nm)", 1e9,
                         "residual_m", False),
    "viscosity": ("pressure_Pa", "pressure p (MPa)", 1e-6, "viscosity_measured_Pa_s",
                  "viscosity_model_Pa_s", "viscosity η (mPa·s)", 1e3, "residual_ln_eta", False),
    "polach": ("creepage", "creepage ξ (%)", 100.0, "mu_torlab", "mu_polach",
               "creep force F/N (–)", 1.0, "residual", False),
}
_RES_LABEL = {"layer_hpt": ("residual Δτ (MPa)", 1e-6),
              "layer_traction": ("residual Δμ (–)", 1.0),
              "temperature": ("residual Δμ (–)", 1.0), "film": ("residual Δh (nm)", 1e9),
              "film_temperature": ("residual Δh (nm)", 1e9),
              "viscosity": ("residual Δln η (–)", 1.0),
              "polach": ("Polach − torlab ΔF/N (–)", 1.0)}
#: legend names of the data and the model where they are not a measurement and a model
_LEGEND = {"polach": ("torlab", "Polach")}


#: figure titles of the fit kinds, in words
KIND_TITLES = {"layer_hpt": "Third-body layer from HPT tests",
               "layer_traction": "Third-body layer from a traction curve",
               "temperature": "Temperature coefficients of the layer",
               "film": "Film thickness against rolling speed",
               "film_temperature": "Film thickness at one rolling speed against temperature",
               "viscosity": "Viscosity against pressure",
               "polach": "Polach's law against torlab's creep forces",
               "amount_crossing": "Friction against applied amount",
               "removal": "Removal of the layer"}


def fit_figure(result: Any, title: str | None = None,
               model_curve: tuple[Any, Any] | None = None) -> Any:
    """Data against the fitted model (top) and the residuals (bottom).

    Parameters
    ----------
    result
        A :class:`~torlab.fit.result.FitResult`.
    title
        Figure title; default: what was fitted, in words, and the data's source.
    model_curve
        ``(x, y)`` of the fitted model on a dense grid (x in the data's SI unit); drawn
        instead of the model joined at the measured points.

    Returns
    -------
    matplotlib.figure.Figure
    """
    return _draw(_spec(result, title, model_curve))


@dataclass
class _Spec:
    """What a fit figure shows: its lines in drawing order (axes 0: data and model, 1: the
    residuals; data, format, style, legend label), its texts and scales, and the marks
    drawn after the lines (the film temperature scaling's error bars and note)."""

    lines: list[tuple[int, Any, Any, str, dict[str, Any], str | None]] = field(
        default_factory=list)
    texts: tuple[str, str, str, str] = ("", "", "", "")  # y label, residual label, x label, title
    loglog: bool = False
    marks: Callable[[Any], None] | None = None

    def add(self, axes: int, x: Any, y: Any, fmt: str, label: str | None = None,
            **style: Any) -> None:
        self.lines.append((axes, np.asarray(x, dtype=float), np.asarray(y, dtype=float), fmt,
                           style, label))

    def layout(self) -> Hashable | None:
        """Everything of the figure but its numbers and texts: two figures of the same
        layout differ only in their lines' data, their texts and their legend labels
        (:func:`_refill`).  None for a figure with marks (never refilled)."""
        if self.marks is not None:
            return None
        return (self.loglog, tuple((a, fmt, tuple(sorted(style.items())), _shown(label),
                                    x.size == 0, y.size == 0)
                                   for a, x, y, fmt, style, label in self.lines))


def _shown(label: str | None) -> bool:
    """Whether a line's label is a legend entry (matplotlib leaves out ``_``-names)."""
    return label is not None and not label.startswith("_")


def _spec(result: Any, title: str | None, model_curve: tuple[Any, Any] | None) -> _Spec:
    """What :func:`fit_figure` draws for ``result``, as data (:class:`_Spec`)."""
    from torlab.reports.plotting import colours, fit_units, param_text

    s = _Spec()
    d = result.data
    xc, xl, xf, ym, ymod, yl, yf, rc, loglog = _layout(result)
    groups = [(None, d)] if "curve" not in d or d["curve"].nunique() == 1 else list(d.groupby("curve"))
    col = colours(g for g, _ in groups)
    many = len(groups) > 1
    data_name, model_name = _LEGEND.get(result.kind, ("measured", "model"))
    if result.kind == "temperature":
        sym = _symbol(ym.removesuffix("_measured"))
        data_name, model_name = f"{sym} measured", f"{sym} model"
    names = _curve_names(result, [g for g, _ in groups], data_name)
    for g, sub in groups:
        x = sub[xc].to_numpy() * xf
        order = np.argsort(x, kind="stable")
        c = col[g]
        dense = len(x) > 200
        ms, alpha = (2.0, 0.55) if dense else (4.5, 1.0)
        s.add(0, x, sub[ym].to_numpy() * yf, "o", ms=ms, mew=0, alpha=alpha, color=c,
              label=data_name if g is None else names[g])
        if result.kind == "film_temperature":
            pass  # the fitted exponential on a dense grid (_film_temperature_marks)
        elif model_curve is None or g is not None:
            # several curves of one fit: each curve's model in its colour, one legend entry
            s.add(0, x[order], sub[ymod].to_numpy()[order] * yf, "-", lw=1.3,
                  color="0.1" if not many else c, label=None if many else model_name)
        else:
            s.add(0, np.asarray(model_curve[0]) * xf, np.asarray(model_curve[1]) * yf, "-",
                  lw=1.3, color="0.1", label="model")
        s.add(1, x, sub[rc].to_numpy() * _res_label(result)[1], "o", ms=ms, mew=0, alpha=alpha,
              color=c)
    if many and result.kind != "film_temperature":
        s.add(0, [], [], "-", lw=1.3, color="0.1",
              label=f"{model_name} (each curve's line in its colour)")
    if result.kind == "temperature":
        x = d[xc].to_numpy()
        order = np.argsort(x)
        for key in _temperature_keys(result)[:-1]:
            sym = _symbol(key)
            s.add(0, x, d[f"{key}_measured"], "s", ms=5, color=col[groups[0][0]], mfc="white",
                  label=f"{sym} measured")
            s.add(0, x[order], d[f"{key}_model"].to_numpy()[order], "--", color="0.1",
                  label=f"{sym} model")
            s.add(1, x, d[f"residual_{key}"], "s", ms=4.5, mfc="white", color=col[groups[0][0]])
    if result.kind == "film" and "film_thickness_hamrock_dowson_m" in d:
        x = d[xc].to_numpy()
        order = np.argsort(x)
        s.add(0, x[order], d["film_thickness_hamrock_dowson_m"].to_numpy()[order] * yf, ":",
              color="0.3",
              label=f"Hamrock–Dowson, α = {result.params['alpha'] * 1e9:.3g} 1/GPa")
    if result.kind == "film_temperature":
        colour = col[groups[0][0]]
        s.marks = lambda ax: _film_temperature_marks(ax, result, yf, colour)
    s.loglog = loglog
    units = fit_units(result)
    txt = ", ".join(param_text(n, result.params[n], si=units.get(n)) for n in result.names[:4])
    src = _short_source(result.meta.get("source", ""))
    head = title or (KIND_TITLES.get(result.kind, f"{result.kind.replace('_', ' ')} fit")
                     + (f": {src}" if src else ""))
    s.texts = (yl, _res_label(result)[0], xl, f"{head}\n{txt}" if txt and not title else head)
    return s


def _draw(s: _Spec) -> Any:
    """A new figure of ``s``; its lines, in the order of ``s.lines``, are kept on it for
    :func:`_refill`."""
    from torlab.reports.plotting import legend, subplots

    fig, (ax, axr) = subplots(2, 1, sharex=True, figsize=(7.0, 5.6), height_ratios=[3, 1])
    fig._torlab_lines = [(ax, axr)[a].plot(x, y, fmt, label=label, **style)[0]
                         for a, x, y, fmt, style, label in s.lines]
    if s.marks is not None:
        s.marks(ax)
    if s.loglog:
        ax.set_xscale("log")
        ax.set_yscale("log")
        axr.set_xscale("log")
    axr.axhline(0.0, color="k", lw=0.6)
    # the residuals' range always holds the zero line (matplotlib widens it for the line
    # only when zero is outside the range the residuals alone give): the same range as the
    # line's data limits give when a kept figure is refilled
    axr.autoscale(axis="y")
    yl, rl, xl, title = s.texts
    ax.set_ylabel(yl)
    axr.set_ylabel(rl)
    axr.set_xlabel(xl)
    legend(ax)
    ax.set_title(title, fontsize=9)
    return fig


def _refill(fig: Any, s: _Spec) -> None:
    """Make a figure drawn by :func:`_draw` from a spec of the same layout
    (:meth:`_Spec.layout`) show ``s``: the lines' data and labels, the legend's labels and
    the texts; the data limits recomputed and autoscaled as a new figure's are; the layout
    (:func:`torlab.reports.plotting.finish`) done again from the figure's first size."""
    from torlab.reports.plotting import pretty

    ax, axr = fig.axes[:2]
    shown = []
    for line, (_, x, y, _, _, label) in zip(fig._torlab_lines, s.lines, strict=True):
        line.set_data(x, y)
        if label is not None:  # (an unlabelled line keeps the name matplotlib gave it)
            line.set_label(label)
        if _shown(label):
            shown.append(label)
    lg = ax.get_legend()
    for text, label in zip(lg.get_texts() if lg is not None else [], shown, strict=True):
        text.set_text(pretty(label))
    for a in (ax, axr):
        a.relim()
        a.autoscale()
    yl, rl, xl, title = s.texts
    ax.set_ylabel(yl)
    axr.set_ylabel(rl)
    axr.set_xlabel(xl)
    ax.set_title(title, fontsize=9)
    fig._torlab_finished = False


def _whole(result: Any) -> Any:
    """The whole fit result: a :class:`~torlab.fit.result.StoredFit` is read here (where
    its figure is drawn)."""
    return result.whole() if hasattr(result, "whole") else result


def redraw_result_figure(take: Callable[[Hashable], Any], result: Any,
                         title: str | None = None,
                         model_curve: tuple[Any, Any] | None = None) -> tuple[Any, Hashable | None]:
    """:func:`result_figure` drawn into a figure kept from an earlier one where there is one
    of its layout (:func:`torlab.reports.render.draw_task`): the same pixels as a new
    figure, at less of matplotlib's work (its tick objects are made once, the text layout
    of unchanged labels is reused).

    Parameters
    ----------
    take
        ``take(layout)``: the figure of that layout kept from before (drawn by this
        function and rendered since), or None.
    result, title, model_curve
        As for :func:`result_figure`.

    Returns
    -------
    (figure, layout)
        The kept figure refilled (:func:`_refill`) when there is one of this figure's layout
        (:meth:`_Spec.layout`: the kind of each line, its style and legend entry, the
        scales), else a new one; the layout, or None for a figure that is never refilled
        (a removal fit's, the film temperature scaling's).  The figure is not finished
        (:func:`torlab.reports.plotting.finish`).
    """
    result = _whole(result)
    if result.kind == "removal":
        return result_figure(result, title=title), None
    s = _spec(result, title, model_curve)
    layout = s.layout()
    kept = take(layout) if layout is not None else None
    if kept is not None:
        _refill(kept, s)
        return kept, layout
    return _draw(s), layout


def _curve_names(result: Any, groups: list[Any], data_name: str) -> dict[Any, str]:
    """Legend names of the curves of a fit of several: the source file of each (the fit's
    ``meta["curves"]``) where it names them, else the data's name and the curve's."""
    files = result.meta.get("curves") or []
    out = {}
    for g in groups:
        if not isinstance(g, (int, np.integer)):  # a curve named by the fit (v = 5 m/s)
            out[g] = f"{data_name} {g}"
            continue
        name = str(files[int(g)]) if 0 <= int(g) < len(files) else ""
        out[g] = name or f"{data_name} {g}"
    if len(set(out.values())) < len(out):  # the same file twice: number them
        out = {g: f"{n} ({k + 1})" for k, (g, n) in enumerate(out.items())}
    return out


def _film_temperature_marks(ax: Any, result: Any, yf: float, colour: Any) -> None:
    """The film temperature scaling's 95 % error bars (each fit's own, in ln h) and the
    fitted exponential on a dense temperature grid, with the reference speed."""
    d = result.data
    T = d["temperature_C"].to_numpy()
    h = d["film_thickness_measured_m"].to_numpy() * yf
    se = d["film_thickness_se_ln"].to_numpy()
    ax.errorbar(T, h, yerr=[h * (1 - np.exp(-1.96 * se)), h * (np.exp(1.96 * se) - 1)],
                fmt="none", ecolor=colour, elinewidth=1.2, capsize=4, zorder=3,
                label="95 % interval of each fit")
    Tg = np.linspace(T.min(), T.max(), 60)
    h0 = result.params["film_at_reference"] * yf
    b = result.params["film_temperature_coefficient"]
    ax.plot(Tg, h0 * np.exp(b * (Tg - result.meta["reference_temperature_C"])), "-", lw=1.3,
            color="0.1", zorder=1, label="model h(v_ref) exp(b (T − T_ref))")
    lo, hi = result.ci95["film_temperature_coefficient"]
    ax.text(0.98, 0.95, f"v_ref = {result.meta['reference_speed_m_s']:.3g} m/s\n"
            f"b = {b:.3g} 1/K (95 %: {lo:.3g} to {hi:.3g})",
            transform=ax.transAxes, ha="right", va="top", fontsize=8)


def _short_source(src: Any, width: int = 60) -> str:
    """A list of source files short enough for a title line: ``first … last (n files)``
    when the whole list is longer than ``width`` characters (it ran off the figure)."""
    text = str(src or "")
    parts = [x.strip() for x in text.split(",") if x.strip()]
    if len(text) <= width or len(parts) < 3:
        return text
    return f"{parts[0]} … {parts[-1]} ({len(parts)} files)"


def result_figure(result: Any, title: str | None = None,
                  model_curve: tuple[Any, Any] | None = None) -> Any:
    """The figure of a fit result (or a :class:`~torlab.fit.result.StoredFit`, read here)
    by its kind (:class:`~torlab.reports.render.Plot` function; also
    :meth:`~torlab.fit.result.FitResult.plot`): a removal fit's
    measured and modelled coefficient and remaining amount
    (:func:`torlab.reports.retention.removal_figure`), any other fit's data against the
    model and the residuals (:func:`fit_figure`)."""
    result = _whole(result)
    if result.kind == "removal":
        from torlab.reports.retention import removal_figure

        return removal_figure(result, title=title)
    return fit_figure(result, title=title, model_curve=model_curve)


#: how :func:`torlab.reports.render.draw_task` draws it into a kept figure
result_figure.redraw = redraw_result_figure  # type: ignore[attr-defined]


def _layout(result: Any) -> tuple[str, str, float, str, str, str, float, str, bool]:
    """The figure layout of a kind; any other fit draws its ``x_column`` against its
    ``y_column`` (``*_measured*`` -> ``*_model*``) and its first ``residual*`` column."""
    if result.kind == "temperature":
        keys = _temperature_keys(result)
        lay = list(_LAYOUT["temperature"])
        lay[3:6] = (f"{keys[-1]}_measured", f"{keys[-1]}_model",
                    f"limit{'s' if len(keys) > 1 else ''} {', '.join(map(_symbol, keys))} (–)")
        lay[7] = f"residual_{keys[-1]}"
        return tuple(lay)  # type: ignore[return-value]
    if result.kind in _LAYOUT:
        return _LAYOUT[result.kind]
    from torlab.reports.mtm import axis_label

    d = result.data
    xc = result.x_column or d.columns[0]
    ym = result.y_column or next(c for c in d.columns if "measured" in c)
    ymod = ym.replace("measured", "model")
    rc = next((c for c in d.columns if c.startswith("residual")), ym)
    (xl, xf), (yl, yf) = axis_label(xc), axis_label(ym.replace("_measured", ""))
    return xc, xl, xf, ym, ymod if ymod in d else ym, yl, yf, rc, False


def _temperature_keys(result: Any) -> list[str]:
    """The limits of a temperature fit (``mu_c1``, ``mu_c2`` for Voce), in the law's order."""
    d = result.data
    return [c.removesuffix("_measured") for c in d.columns if c.endswith("_measured")]


def _symbol(name: str) -> str:
    """A layer parameter's report symbol (``μc1``), else the name."""
    from torlab.model.layers import all_params

    p = all_params().get(name)
    return p.symbol if p is not None else name


def _res_label(result: Any) -> tuple[str, float]:
    return _RES_LABEL.get(result.kind, (f"residual ({result.residual_unit})", 1.0))
