"""Third-body layer laws: the registry (``docs/model/layers.md``).

:class:`~torlab.model.layers.base.LayerLaw` is the interface (the elastic part and the
onset every law shares, the plastic branch each law declares); each law is one module
here and one line in :data:`LAWS`.  Solvers, fits, bands, the scene schema, the ranges
table and the virtual experiments take their parameter lists from this registry.

>>> from torlab.model.layers import get_law
>>> get_law("voce").names
('mu_c1', 'mu_c2', 'L_mue', 'L_mup', 'mu_c1_T', 'mu_c2_T')
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

from torlab.model.layers.base import LayerLaw, Param
from torlab.model.layers.linear import LINEAR
from torlab.model.layers.perfect import PERFECT
from torlab.model.layers.voce import VOCE

__all__ = ["DEFAULT_LAW", "LAWS", "LayerLaw", "LayerParams", "Param", "all_params",
           "get_law", "hpt_tau"]

#: every layer law, by name; the first is the default (a scene without ``law:``)
LAWS: dict[str, LayerLaw] = {law.name: law for law in (
    VOCE,
    LINEAR,
    PERFECT,
)}
DEFAULT_LAW = next(iter(LAWS))


# --------------------------------------------------------------------------------------------
# parameter values
# --------------------------------------------------------------------------------------------
class _ByLaw(type):
    """``LayerParams(...)`` builds the values of its law's own dataclass."""

    def __call__(cls, *args: Any, law: str | LayerLaw | None = None, **values: Any) -> Any:
        if cls is LayerParams:
            return _params_class(get_law(law))(*args, **values)
        if law is not None and get_law(law) is not cls.law:
            raise TypeError(f"{cls.__name__} holds the {cls.law.name} layer law, not {law!r}")
        return super().__call__(*args, **values)


class LayerParams(metaclass=_ByLaw):
    """The parameter values of one layer law (SI), read as attributes (``lay.mu_c1``).

    ``LayerParams(0.30, 0.45, 10e-6, 20e-6)`` is the Voce law (the default) with its
    parameters in order (``mu_c1, mu_c2, L_mue, L_mup, mu_c1_T, mu_c2_T``);
    ``LayerParams(law="linear", mu_c1=0.3, L_mue=10e-6, k_mu=500.0)`` another law.
    Missing parameters take the law's defaults.  Each law's values are a frozen
    dataclass (a subclass of this one; ``dataclasses.replace`` and ``asdict`` work);
    values may be numpy arrays (one layer per point in the vectorised solvers).
    """

    #: the :class:`LayerLaw` of these values (set on each law's class)
    law: LayerLaw

    @property
    def values(self) -> dict[str, Any]:
        """``{name: value}`` in the law's order."""
        return {n: getattr(self, n) for n in self.law.names}

    def __iter__(self) -> Iterator[Any]:
        return iter(self.values.values())

    def get(self, name: str, default: Any = None) -> Any:
        """A parameter's value, or ``default`` where the law has no such parameter."""
        return getattr(self, name) if name in self.law.names else default

    def replace(self, **values: Any) -> LayerParams:
        """A copy with some values replaced (names of this law only)."""
        import dataclasses

        bad = [k for k in values if k not in self.law.names]
        if bad:
            raise TypeError(f"{', '.join(map(repr, bad))} not a parameter of the {self.law.name} "
                            f"layer law ({', '.join(self.law.names)})")
        return dataclasses.replace(self, **values)

    def map(self, fn: Callable[[Any], Any]) -> LayerParams:
        """A copy with ``fn`` applied to every value (arrays per point in the solvers)."""
        return type(self)(**{k: fn(v) for k, v in self.values.items()})

    def __reduce__(self) -> tuple[Any, ...]:
        return (_rebuild, (self.law.name, self.values))


def _rebuild(law: str, values: dict[str, Any]) -> LayerParams:
    return LayerParams(law=law, **values)


_CLASSES: dict[str, type] = {}


def _params_class(law: LayerLaw) -> type:
    """The frozen dataclass of a law's values (made once)."""
    import dataclasses

    cls = _CLASSES.get(law.name)
    if cls is None or cls.law is not law:
        fields: list[Any] = []
        seen_default = False
        for p in law.params:
            if p.default is not None:
                seen_default = True
                fields.append((p.name, Any, dataclasses.field(default=p.default)))
            elif seen_default:  # a required parameter after a default one: keyword only
                fields.append((p.name, Any, dataclasses.field(kw_only=True)))
            else:
                fields.append((p.name, Any))
        cls = dataclasses.make_dataclass(
            f"{law.name.capitalize()}Params", fields, bases=(LayerParams,), frozen=True,
            namespace={"law": law, "__module__": __name__,
                       "__doc__": f"Values of the {law.name} layer law ({law.title})."})
        _CLASSES[law.name] = cls
    return cls


def get_law(law: str | LayerLaw | None = None) -> LayerLaw:
    """The law called ``law`` (None: the default); a :class:`LayerLaw` is returned as is.

    Raises
    ------
    KeyError
        No such law (the message lists the laws).
    """
    if law is None:
        return LAWS[DEFAULT_LAW]
    if isinstance(law, LayerLaw):
        return law
    try:
        return LAWS[law]
    except KeyError:
        raise KeyError(f"{law!r} is not a layer law ({', '.join(LAWS)})") from None


def all_params() -> dict[str, Param]:
    """Every parameter of every law, by name, in registry order (a name shared by laws --
    the elastic part and the onset -- is one parameter)."""
    out: dict[str, Param] = {}
    for law in LAWS.values():
        for p in law.params:
            out.setdefault(p.name, p)
    return out


def hpt_tau(u: Any, sigma: float, params: LayerParams, dT: float = 0.0) -> np.ndarray:
    """Shear stress [Pa] of the layer against its displacement ``u`` [m] at the constant
    normal stress ``sigma`` [Pa] (the HPT test; rig compliance not included), by the
    layer's own law (:meth:`LayerLaw.hpt_tau`; Voce: thesis Eqs. 5.24, 5.26-5.29)."""
    return params.law.hpt_tau(u, sigma, params, dT)
