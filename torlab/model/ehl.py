"""Elastohydrodynamic film and friction (thesis 5.2.3, Eqs. 5.31–5.40; docs/model/thesis-reading.md).

Film thickness (central, analytical):

* non-dimensional groups, with the effective modulus ``E' = 2 E*``::

      U = eta0 v / (E' rx)      G = alpha E'      W = F_EHL / (E' rx^2)      (Eqs. 5.34–5.36)

* iso-viscous (Esfahanian–Hamrock, water-like liquids), Eq. 5.31::

      hc = 5.08 U^0.66 W^-0.21 rx

* piezo-viscous (Hamrock–Dowson), Eq. 5.32::

      hc = 2.69 U^0.67 G^0.53 W^-0.067 (1 - 0.61 exp(-0.73 D)) rx

  with the ellipticity ``D = b/a`` (``b`` the transverse semi-axis, ``a`` the one
  in the rolling direction).  The thesis prints ``D = a/b`` (Eq. 5.33); Hamrock
  and Dowson's ``k`` is transverse over rolling (docs/model/thesis-reading.md).  For
  the circular contacts of Papers A and B both read 1.

``hc`` depends on the film load only through ``F_EHL^-e`` (``e = 0.21`` or
``0.067``): :class:`FilmThickness` exposes that so the load-sharing solver
(:mod:`torlab.model.loadshare`) evaluates ``hc(F_EHL)`` for free.
``v = 0`` gives ``hc = 0``; ``F_EHL -> 0`` gives ``hc -> inf`` (returned as
``inf``, no warning).

Friction (Eqs. 5.37, 5.40): ``tau_EHL = eta(p) w / hc`` with the Hertz pressure
``p = p0 sqrt(1 - (x/a)^2 - (y/b)^2)`` and the rigid slip velocity ``w``;
``mu_EHL = int tau dA / int p dA``.  Since ``p`` depends only on the elliptic
radius, ``s = sqrt(1 - rho^2)`` turns the area integral into::

    mu_EHL = (3 / p0) int_0^1 tau(p0 s) s ds

(the same for any ``a, b``).  Shear laws (``lubricant.shear``):

* ``newtonian`` (default, Eq. 5.37) ``tau = eta w / h``; for Barus viscosity
  ``int_0^1 exp(c s) s ds = (e^c (c - 1) + 1)/c^2`` (``c = alpha p0``) is used in
  closed form (series for small ``c``, log form for large ``c``);
* ``limiting`` ``tau = min(eta w / h, gamma_L p)``;
* ``eyring`` ``tau = tau0 asinh(eta w / (h tau0))``.

Everything is computed in log space where ``eta`` would overflow.  A Newtonian
film under Barus/Roelands viscosity gives absurd traction at high pressure and
slip: ``mu_EHL`` is returned as long as it is finite in float64, otherwise
:class:`NonPhysicalTractionError` tells the user to choose ``shear: limiting``
or ``eyring``.  The other integrals use composite Gauss–Legendre quadrature on
panels graded towards the contact centre (``s = 1``), where an exponential
viscosity concentrates the integrand.

References
----------
.. [1] Hamrock, B. J., Dowson, D. (1977). Isothermal elastohydrodynamic lubrication of point
   contacts: Part III - Fully flooded results. Journal of Lubrication Technology 99(2),
   264-275. https://doi.org/10.1115/1.3453074
.. [2] Roelands, C. J. A. (1966). Correlational aspects of the
   viscosity-temperature-pressure relationship of lubricating oils. PhD thesis, Delft
   University of Technology (no DOI).
.. [3] Barus, C. (1893). Isothermals, isopiestics and isometrics relative to viscosity.
   American Journal of Science s3-45(266), 87-96.
   https://doi.org/10.2475/ajs.s3-45.266.87
.. [4] Kvarda, D., Galas, R., Omasta, M., Shi, L.-B., Ding, H.-H., Wang, W.-J., Krupka, I.,
   Hartl, M. (2021). Asperity-based model for prediction of traction in
   water-contaminated wheel-rail contact. Tribology International 157, 106900.
   https://doi.org/10.1016/j.triboint.2021.106900
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from torlab.errors import NumericalError, TorlabInputError
from torlab.model.viscosity import ROELANDS_C, ROELANDS_P0_INV, log_eta, roelands_alpha0

__all__ = [
    "FilmThickness",
    "Lubricant",
    "NonPhysicalTractionError",
    "ehl_groups",
    "hc_iso",
    "hc_piezo",
    "mu_ehl",
    "tau_ehl",
    "tau_ehl_field",
]

VISCOSITY_LAWS = ("iso", "barus", "roelands")
SHEAR_LAWS = ("newtonian", "limiting", "eyring")
FILM_FORMULAS = ("iso", "piezo")
#: the load exponent of each film formula (hc ~ F_EHL^-e)
LOAD_EXPONENT = {"iso": 0.21, "piezo": 0.067}
_LN_MAX = math.log(np.finfo(float).max)


class NonPhysicalTractionError(NumericalError):
    """A Newtonian EHL film gives a traction that does not fit in a float.

    Raised by :func:`mu_ehl` / :func:`tau_ehl_field` when ``eta(p) w / h``
    overflows: the message tells the user to choose ``shear: limiting`` or
    ``shear: eyring``.
    """


def _finite(value: float, key: str, *, positive: bool = True, allow_zero: bool = False,
            unit: str = "") -> float:
    v = float(value)
    ok = math.isfinite(v) and (v > 0 or (allow_zero and v == 0) or not positive)
    if not ok:
        what = "a non-negative" if allow_zero else "a positive"
        raise TorlabInputError(f"must be {what} number{f' ({unit})' if unit else ''}, got {value!r}",
                               key=key)
    return v


def _nonneg_array(x, key: str, unit: str) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    if not np.all(np.isfinite(x)) or np.any(x < 0):
        raise TorlabInputError(f"must be finite and >= 0 ({unit})", key=key)
    return x


# ----------------------------------------------------------------------------------------
# lubricant
# ----------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Lubricant:
    """The scene's ``lubricant:`` section, SI units (docs/model/thesis-reading.md).

    Attributes
    ----------
    eta0
        Viscosity at ambient pressure [Pa s], > 0.
    viscosity
        ``"iso"`` (constant), ``"barus"`` (Eq. 5.39) or ``"roelands"`` (Eq. 5.38).
    alpha
        Pressure-viscosity coefficient [1/Pa], >= 0: the Barus law, and ``G`` in
        the Hamrock–Dowson film formula.  Without ``alpha`` but with ``Z`` the
        film formula uses the Roelands initial slope ``(ln eta0 + 9.67) 5.1e-9 Z``.
    Z
        Roelands pressure index (-), > 0; the Roelands law needs
        ``eta0 > exp(-9.67) = 6.3e-5 Pa s`` (else viscosity would fall with pressure).
    shear
        ``"newtonian"`` (default), ``"limiting"`` or ``"eyring"``.
    gamma_L
        Limiting shear stress coefficient (``tau <= gamma_L p``), ``limiting`` only.
    tau0
        Eyring stress [Pa], ``eyring`` only.
    film
        Film formula: ``"iso"`` (Eq. 5.31) or ``"piezo"`` (Eq. 5.32); ``None``
        chooses ``iso`` for ``viscosity: iso`` and ``piezo`` otherwise.
    """

    eta0: float
    viscosity: str = "iso"
    alpha: float | None = None
    Z: float | None = None
    shear: str = "newtonian"
    gamma_L: float | None = None
    tau0: float | None = None
    film: str | None = None

    def __post_init__(self) -> None:
        _finite(self.eta0, "lubricant.eta0", unit="Pa s")
        if self.viscosity not in VISCOSITY_LAWS:
            raise TorlabInputError(f"unknown viscosity law {self.viscosity!r} "
                                   f"({' | '.join(VISCOSITY_LAWS)})", key="lubricant.viscosity")
        if self.shear not in SHEAR_LAWS:
            raise TorlabInputError(f"unknown shear law {self.shear!r} ({' | '.join(SHEAR_LAWS)})",
                                   key="lubricant.shear")
        if self.film is not None and self.film not in FILM_FORMULAS:
            raise TorlabInputError(f"unknown film formula {self.film!r} (iso | piezo)",
                                   key="lubricant.film")
        if self.alpha is not None:
            _finite(self.alpha, "lubricant.alpha", allow_zero=True, unit="1/Pa")
        if self.viscosity == "barus" and self.alpha is None:
            raise TorlabInputError("the Barus law needs alpha", key="lubricant.alpha")
        if self.viscosity == "roelands" and self.Z is None:
            raise TorlabInputError("the Roelands law needs Z", key="lubricant.Z")
        if self.Z is not None:
            _finite(self.Z, "lubricant.Z", unit="-")
            if math.log(self.eta0) + ROELANDS_C <= 0:
                raise TorlabInputError(
                    f"the Roelands law needs eta0 > {math.exp(-ROELANDS_C):.3g} Pa s "
                    f"(its eta_inf), got {self.eta0!r}", key="lubricant.eta0")
        if self.shear == "limiting":
            if self.gamma_L is None:
                raise TorlabInputError("the limiting shear law needs gamma_L",
                                       key="lubricant.gamma_L")
            _finite(self.gamma_L, "lubricant.gamma_L", unit="-")
        if self.shear == "eyring":
            if self.tau0 is None:
                raise TorlabInputError("the Eyring law needs tau0", key="lubricant.tau0")
            _finite(self.tau0, "lubricant.tau0", unit="Pa")
        if self.film_formula == "piezo":
            self.film_alpha  # noqa: B018 (validates)

    @property
    def film_formula(self) -> str:
        """``"iso"`` or ``"piezo"``: the scene's choice or the default for the viscosity law."""
        if self.film is not None:
            return self.film
        return "iso" if self.viscosity == "iso" else "piezo"

    @property
    def film_alpha(self) -> float:
        """``alpha`` for ``G = alpha E'`` [1/Pa]: given, else the Roelands initial slope
        ``(ln eta0 + 9.67) 5.1e-9 Z``; must be > 0 for the piezo-viscous formula."""
        if self.alpha is not None:
            alpha = float(self.alpha)
        elif self.Z is not None:
            alpha = float(roelands_alpha0(self.eta0, float(self.Z)))
        else:
            raise TorlabInputError("the piezo-viscous film formula needs alpha (or Roelands Z)",
                                   key="lubricant.alpha")
        if not alpha > 0:
            raise TorlabInputError("the piezo-viscous film formula needs alpha > 0 "
                                   "(G = alpha E')", key="lubricant.alpha")
        return alpha

    def log_eta(self, p: np.ndarray | float) -> np.ndarray:
        """``ln eta(p)`` [Pa s] of the viscosity law (:mod:`torlab.model.viscosity`)."""
        return log_eta(p, self.viscosity, self.eta0, alpha=float(self.alpha or 0.0),
                       Z=float(self.Z or 0.0))


# ----------------------------------------------------------------------------------------
# film thickness
# ----------------------------------------------------------------------------------------

def ehl_groups(v: np.ndarray | float, F_EHL: np.ndarray | float, E_star: float, rx: float,
               eta0: float, alpha: float = 0.0) -> tuple[np.ndarray, float, np.ndarray]:
    """Non-dimensional speed, material and load parameters (Eqs. 5.34–5.36).

    ``U = eta0 v/(E' rx)``, ``G = alpha E'``, ``W = F/(E' rx^2)`` with ``E' = 2 E*``.

    Returns
    -------
    tuple
        ``(U, G, W)``.
    """
    E_prime = 2.0 * _finite(E_star, "materials.E_star", unit="Pa")
    rx = _finite(rx, "contact.rx", unit="m")
    eta0 = _finite(eta0, "lubricant.eta0", unit="Pa s")
    v = _nonneg_array(v, "kinematics.speed", "m/s")
    F_EHL = _nonneg_array(F_EHL, "contact.load", "N")
    return eta0 * v / (E_prime * rx), float(alpha) * E_prime, F_EHL / (E_prime * rx * rx)


def _hc(prefactor: np.ndarray, u_exp: float, U: np.ndarray, W: np.ndarray, w_exp: float,
        rx: float) -> np.ndarray:
    """``prefactor U^u_exp W^-w_exp rx``: 0 where U = 0, inf where W = 0 < U."""
    U, W = np.broadcast_arrays(U, W)
    out = np.zeros(U.shape)
    film = U > 0
    ok = film & (W > 0)
    out[film & ~ok] = np.inf
    pref = np.broadcast_to(prefactor, U.shape)
    out[ok] = pref[ok] * U[ok] ** u_exp * W[ok] ** (-w_exp) * rx
    return out


def hc_iso(v: np.ndarray | float, F_EHL: np.ndarray | float, E_star: float, rx: float,
           eta0: float) -> np.ndarray:
    """Iso-viscous central film thickness (Esfahanian–Hamrock), Eq. 5.31, m.

    ``hc = 5.08 U^0.66 W^-0.21 rx``.

    Parameters
    ----------
    v
        Rolling (entrainment) speed [m/s], >= 0.
    F_EHL
        Load carried by the film [N], >= 0 (0 gives ``inf`` unless ``v = 0``).
    E_star
        Contact modulus ``E*`` [Pa]; ``E' = 2 E*``.
    rx
        Reduced radius in the rolling direction [m].
    eta0
        Viscosity [Pa s].
    """
    U, _, W = ehl_groups(v, F_EHL, E_star, rx, eta0)
    return _hc(np.asarray(5.08), 0.66, U, W, LOAD_EXPONENT["iso"], float(rx))


def hc_piezo(v: np.ndarray | float, F_EHL: np.ndarray | float, E_star: float, rx: float,
             eta0: float, alpha: float, D: float = 1.0) -> np.ndarray:
    """Piezo-viscous central film thickness (Hamrock–Dowson), Eq. 5.32, m.

    ``hc = 2.69 U^0.67 G^0.53 W^-0.067 (1 - 0.61 exp(-0.73 D)) rx`` with ``D = b/a``
    (transverse over rolling-direction semi-axis; the thesis prints a/b, see the
    module docstring).

    Parameters
    ----------
    v, F_EHL, E_star, rx, eta0
        As :func:`hc_iso`.
    alpha
        Pressure-viscosity coefficient [1/Pa], > 0.
    D
        Ellipticity ``b/a`` (-), > 0.
    """
    _finite(alpha, "lubricant.alpha", unit="1/Pa")
    D = _finite(D, "contact.ellipticity", unit="-")
    U, G, W = ehl_groups(v, F_EHL, E_star, rx, eta0, alpha)
    pref = 2.69 * G**0.53 * (1.0 - 0.61 * math.exp(-0.73 * D))
    return _hc(np.asarray(pref), 0.67, U, W, LOAD_EXPONENT["piezo"], float(rx))


@dataclass(frozen=True)
class FilmThickness:
    """Central film thickness of one contact as a function of speed and film load.

    ``hc(v, F_EHL) = C(v) F_EHL^-e``: Eq. 5.31 (``formula="iso"``, ``e = 0.21``) or
    Eq. 5.32 (``"piezo"``, ``e = 0.067``).  Build it with :meth:`from_contact`.

    Attributes
    ----------
    formula
        ``"iso"`` or ``"piezo"``.
    eta0
        Viscosity [Pa s].
    E_star
        Contact modulus [Pa]; ``E' = 2 E*``.
    rx
        Reduced radius in the rolling direction [m].
    alpha
        Pressure-viscosity coefficient for ``G`` [1/Pa], piezo only.
    D
        Ellipticity ``b/a``, piezo only.
    """

    formula: str
    eta0: float
    E_star: float
    rx: float
    alpha: float = 0.0
    D: float = 1.0

    def __post_init__(self) -> None:
        if self.formula not in FILM_FORMULAS:
            raise TorlabInputError(f"unknown film formula {self.formula!r} (iso | piezo)",
                                   key="lubricant.film")
        _finite(self.eta0, "lubricant.eta0", unit="Pa s")
        _finite(self.E_star, "materials.E_star", unit="Pa")
        _finite(self.rx, "contact.rx", unit="m")
        _finite(self.D, "contact.ellipticity", unit="-")
        if self.formula == "piezo":
            _finite(self.alpha, "lubricant.alpha", unit="1/Pa")

    @classmethod
    def from_contact(cls, lubricant: Lubricant, E_star: float, rx: float, a: float,
                     b: float) -> FilmThickness:
        """Film model of ``lubricant`` in a contact with semi-axes ``a`` (rolling) and ``b``."""
        a = _finite(a, "contact.a", unit="m")
        b = _finite(b, "contact.b", unit="m")
        if lubricant.film_formula == "iso":
            return cls("iso", lubricant.eta0, E_star, rx, D=b / a)
        return cls("piezo", lubricant.eta0, E_star, rx, alpha=lubricant.film_alpha, D=b / a)

    @property
    def E_prime(self) -> float:
        """``E' = 2 E*`` [Pa]."""
        return 2.0 * self.E_star

    @property
    def load_exponent(self) -> float:
        """``e`` in ``hc ~ F_EHL^-e``."""
        return LOAD_EXPONENT[self.formula]

    def W(self, F: np.ndarray | float) -> np.ndarray:
        """Non-dimensional load ``F/(E' rx^2)`` (Eqs. 5.36, 5.44, 5.46)."""
        return np.asarray(F, dtype=float) / (self.E_prime * self.rx**2)

    def hc(self, v: np.ndarray | float, F_EHL: np.ndarray | float) -> np.ndarray:
        """Central film thickness [m] at speed ``v`` [m/s] and film load ``F_EHL`` [N]."""
        if self.formula == "iso":
            return hc_iso(v, F_EHL, self.E_star, self.rx, self.eta0)
        return hc_piezo(v, F_EHL, self.E_star, self.rx, self.eta0, self.alpha, self.D)


# ----------------------------------------------------------------------------------------
# traction
# ----------------------------------------------------------------------------------------

@lru_cache(maxsize=1)
def _radial_rule() -> tuple[np.ndarray, np.ndarray]:
    """Composite Gauss–Legendre nodes/weights on s in [0, 1], graded towards s = 1.

    Panels: 16 equal ones on [0, 1/2] ... plus a geometric sequence 1 - 2^-k
    (k = 1..48) so that an integrand ``exp(c s)`` with ``c`` up to ~1e14 is
    resolved; 12 nodes each.
    """
    from scipy.special import roots_legendre

    edges = np.union1d(np.linspace(0.0, 1.0, 17), 1.0 - 2.0 ** -np.arange(1, 49))
    edges = np.append(edges, 1.0) if edges[-1] < 1.0 else edges
    z, w = roots_legendre(12)
    lo, hi = edges[:-1, None], edges[1:, None]
    s = (lo + 0.5 * (hi - lo) * (z + 1.0)).ravel()
    ws = (0.5 * (hi - lo) * w).ravel()
    return s, ws


def _check_traction_args(w, h, p0) -> tuple[np.ndarray, np.ndarray, float]:
    w = np.asarray(w, dtype=float)
    h = np.asarray(h, dtype=float)
    if not np.all(np.isfinite(w)):
        raise TorlabInputError("slip velocity must be finite (m/s)", key="kinematics.slip")
    if not np.all(np.isfinite(h)) or np.any(h < 0):
        raise TorlabInputError("film thickness must be finite and >= 0 (m)", key="film_thickness")
    p0 = _finite(p0, "contact.p0", unit="Pa")
    return w, h, p0


def _log_rate(w_abs: np.ndarray, h: np.ndarray) -> np.ndarray:
    """``ln(|w|/h)``: -inf where w = 0, +inf where h = 0 < |w| (no warnings)."""
    w_abs, h = np.broadcast_arrays(w_abs, h)
    out = np.full(w_abs.shape, -np.inf)
    slip = w_abs > 0
    film = h > 0
    out[slip & ~film] = np.inf
    ok = slip & film
    out[ok] = np.log(w_abs[ok]) - np.log(h[ok])
    return out


def _log_tau(lub: Lubricant, log_eta_p: np.ndarray, log_rate: np.ndarray,
             p: np.ndarray) -> np.ndarray:
    """``ln tau`` of the shear law (broadcast ``log_eta_p``/``p`` with ``log_rate``)."""
    ln_newton = log_eta_p + log_rate  # ln(eta w / h); -inf where w = 0
    if lub.shear == "newtonian":
        return ln_newton
    if lub.shear == "limiting":
        with np.errstate(divide="ignore"):  # p = 0 at the contact edge: ln 0 = -inf is right
            ln_lim = math.log(float(lub.gamma_L)) + np.log(p)
        return np.minimum(ln_newton, ln_lim)
    # eyring: tau0 asinh(x), x = exp(ln_newton - ln tau0); asinh x = ln 2 + ln x + O(x^-2)
    tau0 = float(lub.tau0)
    lx = ln_newton - math.log(tau0)
    big = lx > 30.0
    small = np.arcsinh(np.exp(np.minimum(lx, 30.0)))
    with np.errstate(divide="ignore"):
        return math.log(tau0) + np.log(np.where(big, math.log(2.0) + lx, small))


def _overflow_error(what: str) -> NonPhysicalTractionError:
    return NonPhysicalTractionError(
        f"the Newtonian EHL shear stress {what} overflows float64 (pressure-viscosity "
        "makes eta(p) w/h astronomically large): choose 'shear: limiting' (tau <= gamma_L p) "
        "or 'shear: eyring' in the lubricant section", key="lubricant.shear")


def _log_J_newtonian(lub: Lubricant, p0: float) -> float:
    """``ln int_0^1 eta(p0 s) s ds`` [Pa s]."""
    ln_eta0 = math.log(lub.eta0)
    if lub.viscosity == "iso":
        return ln_eta0 - math.log(2.0)
    if lub.viscosity == "barus":
        c = float(lub.alpha) * p0
        if c < 0.5:  # series sum_k c^k / (k! (k+2)); 25 terms reach 1e-25 at c = 0.5
            k = np.arange(25.0)
            series = np.sum(np.cumprod(np.concatenate(([1.0], c / k[1:]))) / (k + 2.0))
            return ln_eta0 + math.log(float(series))
        return ln_eta0 + c + math.log(c - 1.0 + math.exp(-c)) - 2.0 * math.log(c)
    s, ws = _radial_rule()
    f = lub.log_eta(p0 * s)
    fmax = float(np.max(f))
    return fmax + math.log(float(np.sum(ws * s * np.exp(f - fmax))))


def _s_min(lub: Lubricant, p0: float) -> float:
    """Where ``psi(s) = ln eta(p0 s) - ln s`` is smallest on (0, 1].

    ``psi' = p0 d(ln eta)/dp - 1/s`` has one root: for Barus at ``s = 1/(alpha p0)``;
    for Roelands where ``(ln eta0 + 9.67) Z b p (1 + b p)^(Z-1) = 1`` (increasing in
    ``p``), found by a bracketed root.
    """
    if lub.viscosity == "barus":
        c = float(lub.alpha) * p0
        return 1.0 if c <= 1.0 else 1.0 / c
    from scipy.optimize import brentq

    A = math.log(lub.eta0) + ROELANDS_C
    Z = float(lub.Z)
    bp = ROELANDS_P0_INV

    def q(p: float) -> float:
        return A * Z * bp * p * (1.0 + bp * p) ** (Z - 1.0) - 1.0

    if q(p0) <= 0.0:
        return 1.0
    return float(brentq(q, 0.0, p0, xtol=1e-300, rtol=4 * np.finfo(float).eps)) / p0


def _mu_limiting(lub: Lubricant, p0: float, log_rate: np.ndarray) -> np.ndarray:
    """``mu_EHL`` for ``tau = min(eta r, gamma_L p)`` (``r = |w|/h``) with the kinks located.

    With ``u = ln s``, ``d(u) = ln(eta(p0 s) r) - ln(gamma_L p0 s) = psi(u) - T``,
    ``psi(u) = ln eta(p0 e^u) - u`` and ``T = ln(gamma_L p0) - ln r``.  ``psi``
    decreases then increases (:func:`_s_min`), so the Newtonian branch holds on one
    interval ``[s1, s2]`` and the limiting one outside it::

        int_0^1 tau s ds = gamma_L p0 (s1^3 + 1 - s2^3)/3 + r int_s1^s2 eta(p0 s) s ds

    ``s1`` and ``s2`` are bracketed from a table of ``psi`` on each monotone branch
    and refined together by one call of
    :func:`torlab.model.asperity.bracketed_root`; the Newtonian part uses the
    graded Gauss–Legendre rule mapped onto ``[s1, s2]``.
    """
    from torlab.model.asperity import bracketed_root

    lr = np.asarray(log_rate, dtype=float)
    flat = lr.ravel()
    gp = float(lub.gamma_L) * p0
    target = math.log(gp) - flat  # T; +inf where w = 0, -inf where h = 0

    def psi(u: np.ndarray) -> np.ndarray:
        return lub.log_eta(p0 * np.exp(u)) - u

    def d(u: np.ndarray, T: np.ndarray) -> np.ndarray:
        return psi(u) - T

    u_m = math.log(_s_min(lub, p0))
    u_tiny = math.log(1e-300)
    left = np.linspace(u_tiny, u_m, 128)  # psi decreasing
    right = np.linspace(u_m, 0.0, 65)  # psi increasing
    psi_l = psi(left)
    psi_r = psi(right)
    newton = target > psi_l[-1]  # somewhere eta r < gamma_L p
    s1 = np.ones_like(flat)  # s1 = s2 = 1: tau = gamma_L p everywhere
    s2 = np.ones_like(flat)
    s1[newton] = 0.0
    # left branch: s1 where psi = T, if T < psi(tiny) (else s1 < 1e-300: 0)
    i1 = np.flatnonzero(newton & (target < psi_l[0]))
    k1 = np.searchsorted(-psi_l, -target[i1], side="right") - 1  # psi_l[k] >= T > psi_l[k+1]
    k1 = np.clip(k1, 0, left.size - 2)
    # right branch: s2 where psi = T, if T < psi(1) (else s2 = 1)
    i2 = np.flatnonzero(newton & (target < psi_r[-1]))
    k2 = np.clip(np.searchsorted(psi_r, target[i2], side="left") - 1, 0, right.size - 2)
    lo = np.concatenate([left[k1], right[k2]])
    hi = np.concatenate([left[k1 + 1], right[k2 + 1]])
    tt = np.concatenate([target[i1], target[i2]])
    if lo.size:
        u, _, _, ok = bracketed_root(d, lo, hi, (tt,), xatol=1e-14)
        if not np.all(ok):  # pragma: no cover - valid brackets always converge
            raise NumericalError("limiting shear law: kink location did not converge")
        s1[i1] = np.exp(u[: i1.size])
        s2[i2] = np.exp(u[i1.size:])
    sg, wg = _radial_rule()
    span = s2 - s1
    s = s1[:, None] + span[:, None] * sg[None, :]
    ln_newton = lub.log_eta(p0 * s) + np.where(newton, flat, 0.0)[:, None]
    vals = np.where(newton[:, None], np.exp(np.minimum(ln_newton, _LN_MAX)) * s, 0.0)
    middle = (vals @ wg) * span
    integral = gp * (s1**3 + 1.0 - s2**3) / 3.0 + middle
    return (3.0 / p0 * integral).reshape(lr.shape)


def mu_ehl(w: np.ndarray | float, h: np.ndarray | float, p0: float,
           lubricant: Lubricant) -> np.ndarray:
    """EHL friction coefficient ``mu_EHL = int tau_EHL dA / int p dA`` (Eqs. 5.37, 5.40).

    Over the Hertz ellipse with ``p = p0 sqrt(1 - rho^2)``; reduced to
    ``(3/p0) int_0^1 tau(p0 s) s ds`` (module docstring), so ``a`` and ``b`` do
    not enter.  Odd in ``w``.

    Parameters
    ----------
    w
        Rigid slip velocity ``w = x1' - x2'`` [m/s], any shape (a traction
        curve: ``creepage * v``).
    h
        Film thickness [m], >= 0, broadcastable with ``w`` (0 with slip: only the
        limiting law gives a finite answer, ``gamma_L``).
    p0
        Maximum Hertz pressure [Pa] of the contact.
    lubricant
        Viscosity and shear law.

    Returns
    -------
    numpy.ndarray
        ``mu_EHL``, shape ``broadcast(w, h)``.

    Raises
    ------
    NonPhysicalTractionError
        If the Newtonian (or Eyring with ``h = 0``) traction overflows float64.
    """
    w, h, p0 = _check_traction_args(w, h, p0)
    sign = np.sign(w)
    log_rate = _log_rate(np.abs(w), h)
    if lubricant.shear == "newtonian":
        log_mu = math.log(3.0 / p0) + _log_J_newtonian(lubricant, p0) + log_rate
        if np.any(log_mu > _LN_MAX):
            raise _overflow_error("integrated over the contact")
        return sign * np.exp(log_mu)
    if lubricant.shear == "limiting" and lubricant.viscosity == "iso":
        # closed form: int_0^1 min(A, B s) s ds = B s_k^3/3 + A (1 - s_k^2)/2 with
        # A = eta0 |w|/h, B = gamma_L p0 and the kink s_k = min(A/B, 1) (A = B s_k there)
        B = float(lubricant.gamma_L) * p0
        s_k = np.exp(np.minimum(math.log(lubricant.eta0) + log_rate - math.log(B), 0.0))
        integral = B * s_k**3 / 3.0 + 0.5 * B * s_k * (1.0 - s_k**2)
        return sign * 3.0 / p0 * integral
    if lubricant.shear == "limiting":
        return sign * _mu_limiting(lubricant, p0, log_rate)
    s, ws = _radial_rule()
    p = p0 * s
    lt = _log_tau(lubricant, lubricant.log_eta(p), log_rate[..., None], p)
    if np.any(lt > _LN_MAX):
        raise _overflow_error("integrated over the contact")
    integral = np.exp(lt) @ (ws * s)
    out = sign * 3.0 / p0 * integral
    if not np.all(np.isfinite(out)):
        raise _overflow_error("integrated over the contact")
    return out


def tau_ehl(p: np.ndarray | float, w: np.ndarray | float, h: np.ndarray | float,
            lubricant: Lubricant) -> np.ndarray:
    """EHL shear stress at pressure ``p`` [Pa], Eq. 5.37 with the chosen shear law.

    ``p``, ``w`` [m/s] and ``h`` [m] broadcast; sign of ``w``.  0 where ``p = 0``
    or ``w = 0``.

    Raises
    ------
    NonPhysicalTractionError
        Where the Newtonian stress overflows float64.
    """
    w, h, _ = _check_traction_args(w, h, 1.0)
    p = np.asarray(p, dtype=float)
    if not np.all(np.isfinite(p)) or np.any(p < 0):
        raise TorlabInputError("pressure must be finite and >= 0 (Pa)", key="pressure")
    p, w, h = np.broadcast_arrays(p, w, h)
    lt = _log_tau(lubricant, lubricant.log_eta(p), _log_rate(np.abs(w), h), p)
    lt = np.where(p > 0, lt, -np.inf)
    if np.any(lt > _LN_MAX):
        raise _overflow_error("at a contact point")
    return np.sign(w) * np.exp(lt)


def tau_ehl_field(x: np.ndarray, y: np.ndarray, w: np.ndarray | float, h: np.ndarray | float,
                  a: float, b: float, p0: float, lubricant: Lubricant) -> np.ndarray:
    """EHL shear stress at contact points ``(x, y)`` (Eq. 5.37), Pa.

    ``tau = law(eta(p), w, h)`` with ``p = p0 sqrt(1 - (x/a)^2 - (y/b)^2)`` and 0
    outside the ellipse.  For the temperature model (heat flux ``q = tau w``) at
    the FASTSIM grid points.

    Parameters
    ----------
    x, y
        Coordinates [m], rolling direction and transverse, broadcastable.
    w
        Rigid slip velocity [m/s], broadcastable.
    h
        Film thickness [m].
    a, b
        Semi-axes [m].
    p0
        Maximum Hertz pressure [Pa].
    lubricant
        Viscosity and shear law.
    """
    a = _finite(a, "contact.a", unit="m")
    b = _finite(b, "contact.b", unit="m")
    p0 = _finite(p0, "contact.p0", unit="Pa")
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    r2 = (x / a) ** 2 + (y / b) ** 2
    p = p0 * np.sqrt(np.maximum(1.0 - r2, 0.0))
    return tau_ehl(p, w, h, lubricant)
