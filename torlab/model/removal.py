"""Product removal driven by frictional energy: laws, the energy of a pass, friction tables.

See ``docs/model/retention.md`` for the derivation and the assumptions; in short:

State and driving quantity
--------------------------
``m`` is the areal density of product in the running band [kg/m^2].  The band
is what the contact runs over: width ``w = 2 b`` (the contact's lateral
extent), on a disc a closed track of length ``2 pi r_track``.  The energy
dissipated per unit band area drives the removal.  In steady rolling the work
of the creep force is all dissipated in the contact (in the sliding zone and
in the layer): the power is ``P = F_x w_slip = mu F |xi| v`` (the elastic
energy taken up at the leading edge is released before the trailing edge,
where the traction limit, and so the stress, goes to zero), which is the
``T gamma`` of railway wear models.  Per pass, each point of the band
is swept once, so the energy per unit band area and pass is

    ``e_pass = P / (v w) = mu(m) F |xi| / w``          [J/m^2]

(independent of the speed at a given creepage).  On a closed track it arrives
at the rate ``dE/dt = P / (L_track w) = e_pass / T_pass``.

Removal laws (``E`` the energy per unit band area, ``N`` the passes)
--------------------------------------------------------------------
* zero order in the amount:   ``dm = -k0 dE``         while ``m > 0``   (k0 in kg/J)
* first order in the amount:  ``dm = -k1 m dE``                          (k1 in m^2/J)
* optional spreading:        ``dm += -s m dN``  a fraction ``s`` of the band's
  product is pushed out of the track by each over-rolling (squeeze-out), not
  consumed by friction; it does not return.  (A spread fraction proportional to
  the dissipated energy could not be told apart from consumption by any friction
  record; a pass-driven one can, because ``E`` and ``N`` grow at different rates
  as ``mu`` changes.)

With ``e_pass(m)`` the scalar ODE ``dm/dN = -h(m)``,
``h = g(m) e_pass(m) + s m`` (``g = k0`` or ``k1 m``) is autonomous, so its
solution is the quadrature ``N(m) = integral_m^m0 dm'/h(m')`` -- no stepping, and
no friction evaluation per pass (:func:`passes_solution`).  Below the dry
anchor the friction is constant and the solution is in closed form.  When the
energy ``E(t)`` and the passes ``N(t)`` are known (a measured time test),
``m(t)`` is in closed form for every law (:func:`amount_from_energy`).

Friction of the remaining amount
--------------------------------
``mu(m)`` is the boundary model (FASTSIM with the third-body layer,
:mod:`torlab.model.fastsim`) of the scene's contact with the layer
``p(m)`` of :class:`~torlab.model.amount.AmountLayer`.  It is evaluated on a
few nodes in ``ln m`` (a few between each pair of tested amounts) and
interpolated monotonically (PCHIP); :class:`MuTable`.  A lubricant film
(``lubricant:`` of the scene) is not part of this model: the retention model
follows the boundary regime the contact reaches once the film left by the
application has gone (Paper B: the recovery after the initial drop).

References
----------
.. [1] Kvarda, D., Skurka, S., Galas, R., Omasta, M., Shi, L.-B., Ding, H.-H., Wang, W.-J.,
   Krupka, I., Hartl, M. (2022). The effect of top of rail lubricant composition on
   adhesion and rheological behaviour. Engineering Science and Technology, an
   International Journal 35, 101100. https://doi.org/10.1016/j.jestch.2022.101100
.. [2] Kvarda, D., Galas, R., Omasta, M., Dzimko, M., Krupka, I., Hartl, M. (2022). Shear
   properties of top-of-rail products in numerical modelling. Proceedings of the
   Institution of Mechanical Engineers, Part F: Journal of Rail and Rapid Transit.
   https://doi.org/10.1177/09544097221138374
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from torlab.errors import TorlabInputError

if TYPE_CHECKING:
    from torlab.scene import Scene

__all__ = [
    "LAWS",
    "Band",
    "MuTable",
    "RemovalLaw",
    "amount_from_energy",
    "band_of",
    "boundary_scene",
    "energy_per_pass",
    "mu_of_layers",
    "mu_table",
    "passes_solution",
]

#: the removal laws (names as reported)
LAWS = ("zero_order", "first_order", "zero_order+spread", "first_order+spread")
#: unit of each law parameter (SI)
LAW_UNITS = {"k0": "kg/J", "k1": "m^2/J", "spread": "1/pass", "transfer": "-"}


@dataclass(frozen=True)
class RemovalLaw:
    """A removal law with its parameters (module docstring).

    Attributes
    ----------
    order
        0 (``dm/dE = -k0``) or 1 (``dm/dE = -k1 m``).
    k
        ``k0`` [kg/J] or ``k1`` [m^2/J], >= 0.
    spread
        Fraction of the band's product spread out of the track per pass (>= 0).
    """

    order: int
    k: float
    spread: float = 0.0

    def __post_init__(self) -> None:
        if self.order not in (0, 1):
            raise TorlabInputError(f"removal law order must be 0 or 1, got {self.order}")
        if not (math.isfinite(self.k) and self.k >= 0):
            raise TorlabInputError(f"removal rate must be a non-negative number, got {self.k}")
        if not (math.isfinite(self.spread) and self.spread >= 0):
            raise TorlabInputError(f"spread fraction must be a non-negative number, got "
                                   f"{self.spread}")

    @property
    def name(self) -> str:
        """``zero_order`` / ``first_order`` (``+spread`` with spreading)."""
        base = "zero_order" if self.order == 0 else "first_order"
        return base + ("+spread" if self.spread > 0 else "")

    @property
    def k_name(self) -> str:
        """``k0`` or ``k1``."""
        return f"k{self.order}"

    @classmethod
    def named(cls, name: str, k: float, spread: float = 0.0) -> RemovalLaw:
        """Law from its name (:data:`LAWS`)."""
        if name not in LAWS:
            raise TorlabInputError(f"unknown removal law {name!r}; use one of {', '.join(LAWS)}",
                                   key="law")
        return cls(0 if name.startswith("zero") else 1, k, spread)


# ---------------------------------------------------------------------------------------------
# geometry and energy
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Band:
    """The running band that holds the product.

    Attributes
    ----------
    width
        Band width ``w`` [m]: the contact's lateral extent ``2 b``.
    track_length
        Length of a closed track [m], ``2 pi r_track`` on a disc; None on a rail
        (open track: each pass meets the band once).
    kind
        ``"disc"`` or ``"rail"`` (for reports).
    """

    width: float
    track_length: float | None = None
    kind: str = "rail"

    @property
    def area(self) -> float | None:
        """Area of a closed track [m^2], None on a rail."""
        return None if self.track_length is None else self.width * self.track_length

    def pass_interval(self, speed: float) -> float | None:
        """Time between two passes of a band point [s]: ``L_track / v``; None on a rail."""
        if self.track_length is None or speed <= 0:
            return None
        return self.track_length / speed


def band_of(contact: Any, track_radius: float | None = None) -> Band:
    """The band of a resolved contact: ``w = 2 b``; a disc track of radius ``track_radius``.

    Raises
    ------
    TorlabInputError
        Non-positive track radius.
    """
    w = 2.0 * float(contact.patch.b)
    if track_radius is None:
        return Band(width=w, track_length=None, kind="rail")
    if not (math.isfinite(track_radius) and track_radius > 0):
        raise TorlabInputError(f"track radius must be positive, got {track_radius}",
                               key="track_radius")
    return Band(width=w, track_length=2.0 * math.pi * track_radius, kind="disc")


def energy_per_pass(mu: Any, load: float, creepage: float, width: float) -> np.ndarray:
    """Frictional energy per unit band area and pass ``e = mu F |xi| / w`` [J/m^2].

    The creep-force power ``P = mu F |xi| v`` spread over the band swept per unit
    time ``v w`` (module docstring).
    """
    return np.abs(np.asarray(mu, dtype=float)) * load * abs(creepage) / width


def boundary_scene(scene: Scene, temperature_coefficients: tuple[float, float] = (0.0, 0.0)
                   ) -> tuple[Any, list[str]]:
    """The scene without what the retention model does not use, and what was dropped.

    The lubricant film (see the module docstring) and the roughness go; the
    flash temperature goes too when the layer's temperature coefficients
    are zero (then it cannot change the coefficient).
    """
    notes: list[str] = []
    upd: dict[str, Any] = {}
    if scene.thermal is not None and not any(temperature_coefficients):
        upd["thermal"] = None
        notes.append("contact temperature: not modelled (the layer's temperature coefficients "
                     "are zero, so heating does not change the coefficient)")
    if scene.lubricant is not None:
        upd["lubricant"] = None
        notes.append("lubricant film: not modelled (the retention model follows the boundary "
                     "regime after the film left by the application has gone)")
    if scene.roughness is not None:
        upd["roughness"] = None
    if scene.boundary is None:
        from torlab.model.layers import LayerParams
        from torlab.scene import boundary_of

        upd["boundary"] = boundary_of(LayerParams(0.3, 0.3))  # replaced by each amount's layer
    return (scene.model_copy(update=upd) if upd else scene), notes


def mu_of_layers(scene: Scene, layers: list[Any], creepage: Any) -> np.ndarray:
    """Boundary coefficient (FASTSIM with the layer, Eq. 5.30) of each layer -> ``(n_layers, n_xi)``.

    ``scene``'s contact, kinematics, thermal and grid; the layer replaced by each of
    ``layers`` (:class:`~torlab.model.layers.LayerParams`).  A lubricant is ignored
    (:func:`boundary_scene`).
    """
    from torlab.model.contact import build_contact
    from torlab.model.fastsim import boundary_traction
    from torlab.model.prediction import fastsim_grid, fastsim_problem

    Tc = tuple(layers[0].law.temperature_coefficients(layers[0])) if layers else ()
    sc, _ = boundary_scene(scene, Tc)
    contact = build_contact(sc)
    prob = fastsim_problem(sc, contact)
    grid = fastsim_grid(sc)
    xi = np.atleast_1d(np.asarray(creepage, dtype=float))
    return np.array([np.abs(boundary_traction(replace(prob, layer=L), xi, grid).mu)
                     for L in layers])


# ---------------------------------------------------------------------------------------------
# friction against the remaining amount
# ---------------------------------------------------------------------------------------------
@dataclass
class MuTable:
    """Boundary coefficient on nodes in ``ln m`` (and creepage), interpolated monotonically.

    Attributes
    ----------
    x
        ``ln m`` nodes (m in kg/m^2), increasing; ``x[0]`` is the dry anchor.
    creepage
        Creepages of the columns.
    mu
        ``(n_x, n_xi)`` coefficient.
    params
        ``(n_x, k)`` layer parameters at the nodes (the layer law's ``fit_names``).
    grad
        ``(n_x, n_xi, k)`` derivatives of ``mu`` by the layer parameters
        (forward differences at the layer's nodes, linear in ``ln m`` between), or None.
    m_max
        Largest amount of the table [kg/m^2].
    """

    x: np.ndarray
    creepage: np.ndarray
    mu: np.ndarray
    params: np.ndarray
    grad: np.ndarray | None = None
    m_max: float = math.inf
    n_evaluations: int = 0

    @property
    def m_dry(self) -> float:
        """The dry anchor [kg/m^2]: below it ``mu`` is the dry coefficient."""
        return float(math.exp(self.x[0]))

    @property
    def mu_dry(self) -> np.ndarray:
        """Dry coefficient per creepage."""
        return self.mu[0]

    def curve(self, column: int = 0, mu_nodes: np.ndarray | None = None) -> Any:
        """Monotone interpolant ``x -> mu`` of one creepage column (or of given node values
        ``(n_x, ...)``, e.g. one column per parameter draw)."""
        from scipy.interpolate import PchipInterpolator

        y = self.mu[:, column] if mu_nodes is None else mu_nodes
        return PchipInterpolator(self.x, y, axis=0, extrapolate=False)

    def __call__(self, m: Any, column: int = 0) -> np.ndarray:
        """``mu`` at amounts ``m`` [kg/m^2] for one creepage column."""
        m = np.asarray(m, dtype=float)
        x = np.log(np.clip(m, self.m_dry, self.m_max))
        return self.curve(column)(x)

    def draw_nodes(self, layer: Any, node_draws: np.ndarray) -> np.ndarray:
        """``(n_x, n_xi, n_draws)`` coefficients of parameter draws, linearised at the nodes.

        ``mu_d = mu + grad . (p_d - p)`` with ``p_d`` the layer of each draw of
        :meth:`~torlab.model.amount.AmountLayer.draw_nodes` at the table's nodes.
        """
        if self.grad is None:
            raise ValueError("table built without gradients")
        pd = layer.draw_params(np.exp(self.x), node_draws)  # (n_x, n_draws, k)
        dp = pd - self.params[:, None, :]
        return self.mu[:, :, None] + np.einsum("xcp,xdp->xcd", self.grad, dp)


def mu_table(scene: Scene, layer: Any, creepage: Any, *, m_top: float | None = None,
             per_interval: int = 6, gradient: bool = False,
             extra: Any = ()) -> MuTable:
    """Boundary coefficient of ``layer(m)`` on ``scene`` at ``creepage``, tabulated in ``ln m``.

    Nodes: the dry anchor and the tested amounts of ``layer``
    (:class:`~torlab.model.amount.AmountLayer`), with ``per_interval - 1``
    nodes between each pair (uniform in ``ln m``), up to ``m_top`` (default the
    largest tested amount), and the amounts ``extra`` (e.g. the applied amount, so
    that the coefficient there is the boundary model's exactly).  One FASTSIM
    call per node (vectorised over the
    creepages); with ``gradient`` one more per parameter and node of the layer (dry anchor and
    tested amounts), the derivatives interpolated linearly in ``ln m`` between them.
    """
    xi = np.atleast_1d(np.asarray(creepage, dtype=float))
    if per_interval < 1:
        raise ValueError("per_interval must be >= 1")
    top = layer.m_max if m_top is None else max(float(m_top), layer.m_max)
    if top > layer.m_max:
        layer.check(top)  # an error unless the layer holds its last fit above the tested range
    nodes = np.log(layer.nodes)
    if top > layer.m_max * (1 + 1e-12):
        nodes = np.r_[nodes, math.log(top)]
    x = np.concatenate([np.linspace(a, b, per_interval + 1)[:-1] for a, b in
                        itertools.pairwise(nodes)] + [nodes[-1:]])
    ex = np.log(np.asarray([v for v in np.atleast_1d(np.asarray(extra, dtype=float))
                            if layer.dry_amount < v < top], dtype=float))
    if ex.size:
        x = np.unique(np.concatenate([x, ex]))
        x = x[np.r_[True, np.diff(x) > 1e-9]]
    P = layer.params_at(np.exp(x))
    P[0] = layer.dry_params
    k = P.shape[1]
    layers = [layer.layer_of(p) for p in P]
    mu = mu_of_layers(scene, layers, xi)
    n_ev = len(layers)
    grad = None
    if gradient:
        # derivatives at the layer's own nodes (dry anchor and tested amounts, where the
        # parameters are known), interpolated linearly in ln m to the table's nodes: the
        # coefficient's sensitivity varies slowly with the amount
        gx = nodes
        Pg = layer.params_at(np.exp(gx))
        Pg[0] = layer.dry_params
        base = P[np.searchsorted(x, gx - 1e-12).clip(0, len(x) - 1)]
        mu_g = mu[np.searchsorted(x, gx - 1e-12).clip(0, len(x) - 1)]
        if not np.allclose(base, Pg, rtol=1e-9, atol=0.0):
            mu_g = mu_of_layers(scene, [layer.layer_of(p) for p in Pg], xi)
            n_ev += len(Pg)
        gg = np.zeros((len(gx), xi.size, k))
        for i in range(k):
            h = np.maximum(1e-3 * np.abs(Pg[:, i]), 1e-12)
            Pp = Pg.copy()
            Pp[:, i] += h
            lp = [layer.layer_of(p) for p in Pp]
            gg[:, :, i] = (mu_of_layers(scene, lp, xi) - mu_g) / h[:, None]
            n_ev += len(lp)
        grad = np.empty((len(x), xi.size, k))
        for c in range(xi.size):
            for i in range(k):
                grad[:, c, i] = np.interp(x, gx, gg[:, c, i])
    return MuTable(x=x, creepage=xi, mu=mu, params=P, grad=grad, m_max=top, n_evaluations=n_ev)


# ---------------------------------------------------------------------------------------------
# solutions of the removal laws
# ---------------------------------------------------------------------------------------------
def amount_from_energy(m0: Any, law_order: int, k: Any, spread: Any, energy: np.ndarray,
                       passes: np.ndarray) -> np.ndarray:
    """Remaining amount for known energy ``E(t)`` and passes ``N(t)`` (closed forms).

    ``energy`` and ``passes`` are cumulative from the application, along a
    record (last axis).  ``m0``, ``k`` and ``spread`` may be arrays that
    broadcast against the leading axes (one per parameter draw).

    * first order: ``m = m0 exp(-k1 E - s N)``;
    * zero order:  ``m = exp(-s N) (m0 - k0 integral exp(s N) dE)`` (trapezoidal
      in the record's samples), held at zero once it reaches zero.
    """
    E = np.asarray(energy, dtype=float)
    N = np.asarray(passes, dtype=float)
    m0 = np.asarray(m0, dtype=float)[..., None]
    k = np.asarray(k, dtype=float)[..., None]
    s = np.asarray(spread, dtype=float)[..., None]
    if law_order == 1:
        return m0 * np.exp(-k * E - s * N)
    dE = np.diff(E, axis=-1)
    if np.all(s == 0):
        out = m0 - k * E
    else:
        w = np.exp(s * N)
        wm = 0.5 * (w[..., 1:] + w[..., :-1])
        cum = np.concatenate([np.zeros((*wm.shape[:-1], 1)), np.cumsum(wm * dE, axis=-1)],
                             axis=-1)
        out = (m0 - k * cum) / w
    out = np.maximum(out, 0.0)
    # once gone, the product stays gone (the spread term cannot bring it back)
    gone = np.maximum.accumulate(out <= 0, axis=-1)
    return np.where(gone, 0.0, out)


@dataclass
class PassesSolution:
    """``m``, ``mu`` and the energy against passes for one or many parameter sets.

    Built by :func:`passes_solution`; evaluate with :meth:`at`, crossing passes
    with :meth:`crossing`.  Results carry a trailing draws axis ``D`` (1 for a
    single parameter set).  Per draw, ``curves[d]`` holds ``(x, mu, N, E)`` from
    ``m0`` (``N = 0``) down to the dry anchor, ``x = ln m`` decreasing and ``N``
    increasing.
    """

    curves: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]
    m0: np.ndarray
    N_dry: np.ndarray        # passes to reach the dry anchor (0 if m0 is below it; inf: no removal)
    E_dry: np.ndarray        # energy (J/m^2) dissipated meanwhile
    m_start_dry: np.ndarray  # amount where the constant-friction closed form starts
    mu_dry: np.ndarray
    e_dry: np.ndarray
    order: int
    k: np.ndarray
    s: np.ndarray
    m_dry: float
    c: float
    notes: list[str] = field(default_factory=list)

    @property
    def n_draws(self) -> int:
        """Number of parameter sets ``D``."""
        return int(self.m0.size)

    def at(self, passes: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(m, mu, E)`` at the requested passes -> each ``(n_passes, D)``."""
        Nq = np.atleast_1d(np.asarray(passes, dtype=float))
        D = self.n_draws
        m = np.empty((D, Nq.size))  # one contiguous row per draw, transposed at the end
        mu = np.empty((D, Nq.size))
        E = np.empty((D, Nq.size))
        for d in range(D):
            xs, mus, Ns, Es = self.curves[d]
            if not math.isfinite(self.N_dry[d]):  # no removal: constant
                m[d] = self.m0[d]
                mu[d] = mus[0]
                E[d] = Nq * self.c * mus[0]
                continue
            nd = self.N_dry[d]
            k = int(np.searchsorted(Nq, nd, side="right")) if np.all(np.diff(Nq) >= 0) else None
            if k is not None:  # sorted passes: the two regimes are two slices
                a, b = slice(0, k), slice(k, None)
            else:
                a = Nq <= nd
                b = ~a
            m[d, a] = np.exp(np.interp(Nq[a], Ns, xs))
            mu[d, a] = np.interp(Nq[a], Ns, mus)
            E[d, a] = np.interp(Nq[a], Ns, Es)
            dN = Nq[b] - nd
            if dN.size:
                m[d, b] = self._dry_amount(d, dN)
                mu[d, b] = self.mu_dry[d]
                E[d, b] = self.E_dry[d] + self.e_dry[d] * dN
        return m.T, mu.T, E.T

    def _dry_amount(self, d: int, dN: np.ndarray) -> np.ndarray:
        """Closed forms below the dry anchor (constant friction)."""
        m1, e, k, s = self.m_start_dry[d], self.e_dry[d], self.k[d], self.s[d]
        if self.order == 1:
            return m1 * np.exp(-(k * e + s) * dN)
        a = k * e
        out = (m1 + a / s) * np.exp(-s * dN) - a / s if s > 0 else m1 - a * dN
        return np.maximum(out, 0.0)

    def crossing(self, level: Any) -> tuple[np.ndarray, np.ndarray]:
        """Passes (and amount, kg/m^2) at which ``mu`` first reaches ``level`` rising.

        0 where ``mu`` starts at or above ``level``; ``inf`` (amount NaN) where it
        never does (no removal, or a dry coefficient below ``level``).  ``mu`` is
        constant below the dry anchor, so a crossing, if any, lies above it.
        ``level`` is one coefficient or one per draw.
        """
        D = self.n_draws
        Nc = np.full(D, np.inf)
        mc = np.full(D, np.nan)
        levels = np.broadcast_to(np.asarray(level, dtype=float), (D,))
        for d in range(D):
            level = float(levels[d])
            xs, mus, Ns, _ = self.curves[d]
            if mus[0] >= level:
                Nc[d], mc[d] = 0.0, self.m0[d]
                continue
            if not math.isfinite(self.N_dry[d]):
                continue
            hit = np.flatnonzero(mus >= level)
            if hit.size == 0:
                continue
            j = int(hit[0])
            f = (level - mus[j - 1]) / (mus[j] - mus[j - 1])
            Nc[d] = Ns[j - 1] + f * (Ns[j] - Ns[j - 1])
            mc[d] = math.exp(xs[j - 1] + f * (xs[j] - xs[j - 1]))
        return Nc, mc


def cumulative_integral(f: np.ndarray, h: float) -> np.ndarray:
    """Cumulative integral along axis 0 on a uniform grid (from 0 at the first node).

    Trapezoidal sums with the Euler-Maclaurin end correction
    ``- h^2/12 (f'(x) - f'(x_0))`` (derivatives by second-order differences):
    fourth order for smooth integrands, and a few vector operations.
    """
    cum = np.zeros_like(f)
    cum[1:] = np.cumsum(0.5 * h * (f[1:] + f[:-1]), axis=0)
    if f.shape[0] >= 3:
        d = np.gradient(f, h, axis=0, edge_order=2)
        cum -= h * h / 12.0 * (d - d[0])
    return cum


def passes_solution(curve: Any, mu_dry: Any, x_dry: float, m0: Any, order: int, k: Any,
                    spread: Any, c: float, *, n_grid: int = 1025) -> PassesSolution:
    """Solve ``dm/dN = -(g(m) c mu(m) + s m)`` by quadrature (module docstring).

    Parameters
    ----------
    curve
        ``x -> mu`` interpolant (``x = ln m``) returning ``(n, D)`` (or ``(n,)``)
        values, from :meth:`MuTable.curve`; valid from ``x_dry`` up.
    mu_dry
        Dry coefficient(s), scalar or ``(D,)`` (the value below ``x_dry``).
    x_dry
        ``ln`` of the dry anchor.
    m0
        Initial amount(s) [kg/m^2], scalar or ``(D,)``.
    order, k, spread
        The law (``k``, ``spread`` scalars or ``(D,)``).
    c
        ``e_pass = c mu`` (``F |xi| / w``, J/m^2 per pass).
    n_grid
        Points of the quadrature grid in ``ln m`` (trapezoidal sums with the
        Euler-Maclaurin end correction, :func:`cumulative_integral`).
    """
    mu_dry = np.atleast_1d(np.asarray(mu_dry, dtype=float))
    shapes = [np.shape(v) for v in (mu_dry, m0, k, spread)]
    D = max(int(np.prod(sh)) if len(sh) else 1 for sh in shapes)
    mu_dry = np.broadcast_to(mu_dry, (D,)).copy()
    m0 = np.broadcast_to(np.asarray(m0, dtype=float), (D,)).copy()
    k = np.broadcast_to(np.asarray(k, dtype=float), (D,)).copy()
    s = np.broadcast_to(np.asarray(spread, dtype=float), (D,)).copy()
    m_dry = math.exp(x_dry)
    x0 = np.log(np.maximum(m0, m_dry))
    top = float(np.max(x0))
    x = np.linspace(x_dry, max(top, x_dry + 1e-9), n_grid)
    mu_x = np.asarray(curve(x), dtype=float).reshape(n_grid, -1)
    mu_x = np.broadcast_to(mu_x, (n_grid, D)).copy()
    mu_x[0] = mu_dry
    mx = np.exp(x)[:, None]
    e = c * mu_x
    g = k[None, :] * (mx if order == 1 else 1.0)
    h = g * e + s[None, :] * mx
    none = np.all(h <= 0, axis=0)       # no removal at all (k = s = 0)
    hh = np.where(h > 0, h, 1.0)
    fN = mx / hh                        # dN/dx
    fE = mx * e / hh                    # dE/dx
    h_x = float(x[1] - x[0])
    IN = cumulative_integral(fN, h_x)
    IE = cumulative_integral(fE, h_x)
    curves = []
    N_dry = np.zeros(D)
    E_dry = np.zeros(D)
    for d in range(D):
        mu0 = float(np.interp(x0[d], x, mu_x[:, d]))
        if m0[d] <= m_dry or none[d]:
            curves.append((np.array([x0[d]]), np.array([mu0 if m0[d] > m_dry else mu_dry[d]]),
                           np.array([0.0]), np.array([0.0])))
            N_dry[d] = np.inf if none[d] else 0.0
            continue
        I0 = float(np.interp(x0[d], x, IN[:, d]))
        J0 = float(np.interp(x0[d], x, IE[:, d]))
        sel = np.flatnonzero(x < x0[d])[::-1]
        xs = np.r_[x0[d], x[sel]]
        curves.append((xs, np.r_[mu0, mu_x[sel, d]], np.r_[0.0, I0 - IN[sel, d]],
                       np.r_[0.0, J0 - IE[sel, d]]))
        N_dry[d], E_dry[d] = I0, J0
    return PassesSolution(curves=curves, m0=m0, N_dry=N_dry, E_dry=E_dry,
                          m_start_dry=np.minimum(m0, m_dry), mu_dry=mu_dry, e_dry=c * mu_dry,
                          order=order, k=k, s=s, m_dry=m_dry, c=c)
