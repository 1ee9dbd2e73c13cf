"""The discretisation grid and the Hertz pressure on it.

The potential contact area is a rectangle divided into ``mx x my`` equal
rectangular elements (``x`` the rolling direction).  Arrays on the grid have the
shape ``(mx, my)``: ``arr[i]`` is the column of elements at ``x_i``, the unit of
the steady-rolling scheme's march from the leading edge (large ``x``) to the
trailing edge.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Grid", "ellipse_grid", "hertz_pressure"]


@dataclass(frozen=True)
class Grid:
    """A rectangular grid of ``mx x my`` elements.

    Attributes
    ----------
    x0, y0
        Lower corner of the potential contact area [m].
    dx, dy
        Element size [m].
    mx, my
        Number of elements along x (rolling direction) and y.
    """

    x0: float
    y0: float
    dx: float
    dy: float
    mx: int
    my: int

    @property
    def x(self) -> np.ndarray:
        """Element centres along x [m], shape ``(mx,)``."""
        return self.x0 + (np.arange(self.mx) + 0.5) * self.dx

    @property
    def y(self) -> np.ndarray:
        """Element centres along y [m], shape ``(my,)``."""
        return self.y0 + (np.arange(self.my) + 0.5) * self.dy

    @property
    def area(self) -> float:
        """Element area ``dx dy`` [m^2]."""
        return self.dx * self.dy

    def centres(self) -> tuple[np.ndarray, np.ndarray]:
        """``(X, Y)`` of all elements, shape ``(mx, my)`` each."""
        return np.meshgrid(self.x, self.y, indexing="ij")


def ellipse_grid(a: float, b: float, nx: int, ny: int, margin: int = 0) -> Grid:
    """The grid whose ``nx x ny`` inner elements cover the bounding box of the ellipse.

    ``margin`` elements are added on every side (the discrete normal problem's
    contact area may reach slightly beyond the Hertz ellipse).
    """
    dx, dy = 2 * a / nx, 2 * b / ny
    return Grid(x0=-a - margin * dx, y0=-b - margin * dy, dx=dx, dy=dy,
                mx=nx + 2 * margin, my=ny + 2 * margin)


def hertz_pressure(grid: Grid, a: float, b: float, load: float, how: str = "average",
                   nodes: int = 12) -> np.ndarray:
    """Hertz pressure ``p0 sqrt(1 - x^2/a^2 - y^2/b^2)``, ``p0 = 3N/(2 pi a b)``, on the grid [Pa].

    Parameters
    ----------
    grid
        The grid.
    a, b
        Semi-axes [m].
    load
        Normal load [N].
    how
        ``average``: the mean over each element (exact in x, Gauss-Legendre in y with
        ``nodes`` points), so that elements the ellipse's edge cuts carry their share
        and the total is the load to round-off; ``centre``: the value at the element
        centre (CONTACT's prescribed elliptical pressure).
    """
    p0 = 3.0 * load / (2.0 * math.pi * a * b)
    X, Y = grid.centres()
    if how == "centre":
        return p0 * np.sqrt(np.clip(1 - (X / a) ** 2 - (Y / b) ** 2, 0.0, None))
    if how != "average":
        raise ValueError(f"unknown pressure sampling {how!r}")
    t, w = np.polynomial.legendre.leggauss(nodes)
    yq = grid.y[:, None] + 0.5 * grid.dy * t[None, :]           # (my, nodes)
    c = a * np.sqrt(np.clip(1 - (yq / b) ** 2, 0.0, None))      # strip half-length

    def prim(x: np.ndarray, c: np.ndarray) -> np.ndarray:       # integral of sqrt(c^2 - x^2)
        xc = np.clip(x, -c, c)
        with np.errstate(invalid="ignore", divide="ignore"):
            ang = np.where(c > 0, np.arcsin(np.where(c > 0, xc / np.where(c > 0, c, 1), 0)), 0)
        return 0.5 * (xc * np.sqrt(np.clip(c * c - xc * xc, 0, None)) + c * c * ang)

    x1 = (grid.x - grid.dx / 2)[:, None, None]
    x2 = (grid.x + grid.dx / 2)[:, None, None]
    strip = prim(x2, c[None]) - prim(x1, c[None])               # (mx, my, nodes)
    mean = (strip * w).sum(axis=-1) * 0.5 / grid.dx             # average over the element
    return p0 / a * mean
