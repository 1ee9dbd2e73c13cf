"""Influence coefficients of the elastic half-space for piecewise-constant tractions.

Two quasi-identical bodies (the same ``G`` and ``nu``, or Kalker's combined
constants of two materials) deform as one half-space of the combined constants:
a traction ``p`` on body 1 (``-p`` on body 2) produces the displacement
difference ``u = u1 - u2`` of the Boussinesq-Cerruti solution (Johnson, *Contact
Mechanics*, 1985, Eqs. 3.19-3.20; Kalker 1990, *Three-dimensional elastic bodies
in rolling contact*, section 1.5), doubled::

    u_x = 1/(pi G) [ (1 - nu)/r + nu x^2/r^3 ] p_x + nu/(pi G) x y / r^3 p_y
    u_y = nu/(pi G) x y / r^3 p_x + 1/(pi G) [ (1 - nu)/r + nu y^2/r^3 ] p_y
    u_n = (1 - nu)/(pi G) / r p_n

The normal and tangential parts decouple for quasi-identical bodies.  A traction
that is constant on a rectangular element integrates in closed form; with
``x, y`` the element's corner minus the observation point and
``Px = x asinh(y/|x|)``, ``Py = y asinh(x/|y|)``, ``r = sqrt(x^2 + y^2)``,
the antiderivatives are ``1/r -> Px + Py``, ``x^2/r^3 -> Py``, ``y^2/r^3 -> Px``
and ``x y/r^3 -> -r``, summed over the four corners with alternating signs.
(The ``asinh`` form is the usual ``x ln(y + r)`` without its term ``x ln|x|``,
which cancels between the corners and is singular on the element's own lines.)

The coefficients depend only on the offset between two elements, so ``u = A p``
is a discrete convolution, evaluated with ``scipy.fft``: :class:`Influence`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Influence", "coefficients"]


def _px(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``x asinh(y/|x|)``, 0 where ``x = 0``."""
    ax = np.abs(x)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = x * np.arcsinh(y / np.where(ax > 0, ax, 1.0))
    return np.where(ax > 0, out, 0.0)


def _corners(f, X: np.ndarray, Y: np.ndarray, dx: float, dy: float) -> np.ndarray:
    """Sum of ``f`` over the corners of elements centred at offsets ``X, Y`` (alternating signs)."""
    x1, x2 = X - dx / 2, X + dx / 2
    y1, y2 = Y - dy / 2, Y + dy / 2
    return f(x2, y2) - f(x1, y2) - f(x2, y1) + f(x1, y1)


def coefficients(kx: np.ndarray, ky: np.ndarray, dx: float, dy: float, G: float, nu: float
                 ) -> dict[str, np.ndarray]:
    """Influence coefficients for element offsets ``(kx dx, ky dy)`` (observation minus source).

    Parameters
    ----------
    kx, ky
        Integer offsets (broadcast against each other).
    dx, dy
        Element size [m].
    G, nu
        (Combined) shear modulus [Pa] and Poisson ratio.

    Returns
    -------
    dict
        ``xx, xy, yy, nn``: displacement difference [m] per unit traction [Pa] on the
        source element.  ``yx = xy`` (the kernel is symmetric).
    """
    X = np.asarray(kx, dtype=float) * dx
    Y = np.asarray(ky, dtype=float) * dy
    X, Y = np.broadcast_arrays(X, Y)
    px = _corners(_px, X, Y, dx, dy)
    py = _corners(lambda a, b: _px(b, a), X, Y, dx, dy)
    rr = _corners(lambda a, b: -np.hypot(a, b), X, Y, dx, dy)
    c = 1.0 / (math.pi * G)
    return {"xx": c * ((1 - nu) * px + py), "yy": c * (px + (1 - nu) * py),
            "xy": c * nu * rr, "nn": c * (1 - nu) * (px + py)}


@dataclass
class Influence:
    """``u = A p`` on a rectangular grid by FFT (linear, not periodic, convolution).

    Parameters
    ----------
    mx, my
        Elements along x (rolling direction) and y.
    dx, dy
        Element size [m].
    G, nu
        (Combined) elastic constants.
    extra
        Observation columns beyond the grid at large x (the steady-rolling scheme
        needs the displacement one element ahead of the leading column).
    """

    mx: int
    my: int
    dx: float
    dy: float
    G: float
    nu: float
    extra: int = 1
    _spec: dict[str, np.ndarray] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        from scipy import fft

        mo = self.mx + self.extra  # observation columns
        self.nx = fft.next_fast_len(mo + self.mx - 1, real=True)
        self.ny = fft.next_fast_len(2 * self.my - 1, real=True)
        kx = np.arange(self.nx)
        kx = np.where(kx <= mo - 1, kx, kx - self.nx)  # offsets -(mx-1) .. mo-1
        ky = np.arange(self.ny)
        ky = np.where(ky <= self.my - 1, ky, ky - self.ny)
        c = coefficients(kx[:, None], ky[None, :], self.dx, self.dy, self.G, self.nu)
        self.kernel = c
        self._spec = {k: fft.rfft2(v) for k, v in c.items()}

    def block(self, kx: int, component: str) -> np.ndarray:
        """Dense ``my x my`` block: column with offset ``kx`` (observation minus source)."""
        iy = np.arange(self.my)
        ky = iy[:, None] - iy[None, :]
        return coefficients(np.full_like(ky, kx), ky, self.dx, self.dy, self.G, self.nu)[component]

    def _fwd(self, p: np.ndarray) -> np.ndarray:
        from scipy import fft

        return fft.rfft2(p, s=(self.nx, self.ny))

    def _back(self, P: np.ndarray) -> np.ndarray:
        from scipy import fft

        return fft.irfft2(P, s=(self.nx, self.ny))[: self.mx + self.extra, : self.my]

    def tangential(self, px: np.ndarray, py: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Tangential displacement differences ``(u_x, u_y)`` on ``(mx + extra, my)``."""
        u = self.tangential_stacked(np.stack([px, py]))
        return u[0], u[1]

    def tangential_stacked(self, p: np.ndarray) -> np.ndarray:
        """``u`` of tractions stacked as ``(2, mx, my)`` (components first), same layout."""
        from scipy import fft

        P = fft.rfft2(p, s=(self.nx, self.ny))
        s = self._spec
        U = np.stack([s["xx"] * P[0] + s["xy"] * P[1], s["xy"] * P[0] + s["yy"] * P[1]])
        return fft.irfft2(U, s=(self.nx, self.ny))[:, : self.mx + self.extra, : self.my]

    def normal(self, pn: np.ndarray) -> np.ndarray:
        """Normal displacement difference ``u_n`` on ``(mx + extra, my)``."""
        return self._back(self._spec["nn"] * self._fwd(pn))
