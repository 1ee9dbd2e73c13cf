"""The error of torlab's FASTSIM against Kalker's exact theory, case by case.

Kalker's FASTSIM (three flexibilities and the elliptical traction bound,
:mod:`torlab.model.creep`; the ``fastsim-kalker`` boundary method, the thesis's model)
reproduces Kalker's *simplified* theory; this module measures how far that theory lies
from the *exact* one (:mod:`torlab.model.exact`) on a fixed set of cases, against which
the default method, FASTSIM corrected by the exact theory
(:mod:`torlab.model.calibrated`), is checked too (``docs/model/exact.md``, "FASTSIM's
error"; ``docs/model/boundary.md``).

Every case is a Coulomb contact (``mu = 0.3``, ``nu = 0.28``, no layer) given by its
aspect ratio ``a/b`` and Kalker's normalised creepages
(:func:`~torlab.model.exact.rolling.normalised_creepages`)::

    xi* = G a b C11 xi / (3 mu N),  eta* = G a b C22 eta / (3 mu N),
    phi* = G (ab)^(3/2) C23 phi / (3 mu N)

Forces are reported as ``F / (mu N)`` and the spin moment as ``Mz / (mu N c)``,
``c = sqrt(ab)``: with these the results depend on nothing else (the contact's size,
load and modulus drop out).  The linear-theory rows compare FASTSIM's coefficients
``C33`` and ``C32`` (its spin moment at a vanishing spin and lateral creepage) with
Kalker's, which the exact solver reproduces within 0.5 %.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from torlab.model.exact.rolling import (
    ExactContact,
    ExactGrid,
    exact_creep_forces,
    normalised_creepages,
)

__all__ = ["CASES", "ErrorCase", "case_contact", "error_table", "exact_values", "fastsim_values"]

NU = 0.28
MU = 0.3
#: the grids of the table's exact column
TABLE_GRID = ExactGrid(n=40, coarse=24)


@dataclass(frozen=True)
class ErrorCase:
    """One row of the FASTSIM-error table.

    Attributes
    ----------
    name
        Short name.
    a_over_b
        Aspect ratio of the contact (``a`` along the rolling direction).
    xi, eta, phi
        Normalised creepages ``xi*, eta*, phi*`` (module docstring).
    quantities
        What the row compares: ``Fx``, ``Fy``, ``Mz`` (normalised) or ``C33``, ``C32``.
    what
        Description for the table.
    """

    name: str
    a_over_b: float
    xi: float = 0.0
    eta: float = 0.0
    phi: float = 0.0
    quantities: tuple[str, ...] = ("Fx",)
    what: str = ""


#: the cases of the table (``docs/model/exact.md``)
CASES: tuple[ErrorCase, ...] = (
    ErrorCase("xi_small", 1.0, xi=0.1, what="pure xi, circle, small creepage"),
    ErrorCase("xi_large", 1.0, xi=0.75, what="pure xi, circle, large creepage"),
    ErrorCase("traction_curve_A2", 0.5, xi=0.64491,
              what="CONTACT's traction-curve example (Eurosprinter, a/b = 0.5, mu = 0.33): "
                   "xi = 2.8e-3"),
    ErrorCase("spin", 0.5, phi=2 / 3, quantities=("Fy", "Mz"),
              what="pure spin, a/b = 0.5"),
    ErrorCase("lateral_spin", 0.5, eta=2.0, phi=-2 / 3, quantities=("Fy", "Mz"),
              what="lateral creepage against spin, a/b = 0.5"),
    ErrorCase("lateral_spin_same", 0.5, eta=2.0, phi=2 / 3, quantities=("Fy", "Mz"),
              what="lateral creepage with spin, a/b = 0.5"),
    ErrorCase("C33_0.5", 0.5, quantities=("C33", "C32"), what="linear theory, a/b = 0.5"),
    ErrorCase("C33_1", 1.0, quantities=("C33", "C32"), what="linear theory, a/b = 1"),
    ErrorCase("C33_2", 2.0, quantities=("C33", "C32"), what="linear theory, a/b = 2"),
    ErrorCase("full_slip_1", 1.0, eta=6.0, phi=2.0, quantities=("Fy", "Mz"),
              what="full slip, lateral creepage and spin, circle"),
    ErrorCase("full_slip_0.5", 0.5, eta=6.0, phi=2.0, quantities=("Fy", "Mz"),
              what="full slip, lateral creepage and spin, a/b = 0.5"),
    ErrorCase("full_slip_2", 2.0, eta=6.0, phi=-2.0, quantities=("Fy", "Mz"),
              what="full slip, lateral creepage against spin, a/b = 2"),
)


def case_contact(case: ErrorCase) -> ExactContact:
    """The contact of a case: ``sqrt(ab)`` = 6 mm, 100 kN, ``G`` = 82 GPa (the results,
    normalised, depend only on ``a/b``, ``nu`` and the normalised creepages)."""
    c = 6e-3
    s = math.sqrt(case.a_over_b)
    return ExactContact(a=c * s, b=c / s, load=100e3, G=82e9, nu=NU, mu=MU)


def case_creepages(case: ErrorCase, contact: ExactContact) -> tuple[float, float, float]:
    s = normalised_creepages(contact, 1.0, 1.0, 1.0)
    return case.xi / float(s[0]), case.eta / float(s[1]), case.phi / float(s[2])


def case_scales(contact: ExactContact) -> dict[str, float]:
    muN = contact.mu * contact.load
    return {"Fx": muN, "Fy": muN, "Mz": muN * math.sqrt(contact.a * contact.b)}


def exact_values(case: ErrorCase, grid: ExactGrid | None = None
                 ) -> dict[str, tuple[float, float]]:
    """``{quantity: (value, discretisation error)}`` of the exact theory.

    The linear-theory coefficients are Kalker's (his Table E.3, ``torlab.model.kalker``;
    ``C32 = C23``), which the exact solver reproduces within 0.5 %
    (``tests/test_exact.py``); their error is the table's rounding (half a unit of its
    third digit).
    """
    from torlab.model.kalker import C23, C33

    if case.quantities[0] in ("C33", "C32"):
        c33, c23 = C33(case.a_over_b, NU), C23(case.a_over_b, NU)
        return {"C33": (c33, 0.005 * c33), "C32": (c23, 0.005 * c23)}
    contact = case_contact(case)
    xi, eta, phi = case_creepages(case, contact)
    r = exact_creep_forces(contact, xi, eta, phi, grid or TABLE_GRID)
    sc = case_scales(contact)
    return {q: (float(getattr(r, q)[()]) / sc[q], float(getattr(r, q + "_error")[()]) / sc[q])
            for q in case.quantities}


def fastsim_values(case: ErrorCase) -> dict[str, float]:
    """``{quantity: value}`` of torlab's FASTSIM (three flexibilities, elliptical bound)."""
    from torlab.model.creep import CreepProblem, creep_forces
    from torlab.model.kalker import C11, C22, C23, L1, L2, L3
    from torlab.model.layers import LayerParams

    contact = case_contact(case)
    a, b, G = contact.a, contact.b, contact.G
    g = a / b
    linear = case.quantities[0] in ("C33", "C32")
    mu = 1e6 if linear else contact.mu  # the linear theory: a bound never reached
    prob = CreepProblem(a=a, b=b, p0=contact.p0, L1=L1(a, C11(g, NU), G),
                        L2=L2(a, C22(g, NU), G), L3=L3(a, b, C23(g, NU), G),
                        layer=LayerParams(mu_c1=mu, mu_c2=mu))
    if linear:
        c = math.sqrt(a * b)
        small = 1e-6
        rs = creep_forces(prob, 0.0, 0.0, small / c)
        rl = creep_forces(prob, 0.0, small, 0.0)
        return {"C33": float(rs.Mz) / (G * c**3 * small),
                "C32": -float(rl.Mz) / (G * c**3 * small)}
    xi, eta, phi = case_creepages(case, contact)
    r = creep_forces(prob, xi, eta, phi)
    sc = case_scales(contact)
    return {q: float(getattr(r, q)) / sc[q] for q in case.quantities}


def error_table(grid: ExactGrid | None = None, cases: Any = CASES) -> Any:
    """The table: one row per case and quantity, with FASTSIM's relative error.

    Columns ``case, what, a_over_b, xi_star, eta_star, phi_star, quantity, exact,
    exact_error, fastsim, error`` (``fastsim / exact - 1``) and ``error_margin`` (the
    exact value's discretisation error relative to it).
    """
    import pandas as pd

    rows = []
    for case in cases:
        ex = exact_values(case, grid)
        fs = fastsim_values(case)
        for q in case.quantities:
            v, e = ex[q]
            rows.append({"case": case.name, "what": case.what, "a_over_b": case.a_over_b,
                         "xi_star": case.xi, "eta_star": case.eta, "phi_star": case.phi,
                         "quantity": q, "exact": v, "exact_error": e, "fastsim": fs[q],
                         "error": fs[q] / v - 1.0, "error_margin": abs(e / v)})
    return pd.DataFrame(rows)
