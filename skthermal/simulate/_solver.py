"""Exact discretisation and vectorised time stepping of linear thermal networks.

The network ``C dT/dt = -(L + H) T + h T_air(t) + Q(t)`` (``L`` the conductance
Laplacian, ``H = diag(h)`` the convection to air) has a symmetrisable system
matrix: with ``D = C^(1/2)``, ``S = D^-1 (L + H) D^-1`` is symmetric positive
definite. One ``eigh`` per operating point gives the exact matrix exponential,
and in modal coordinates ``z = V^T D T`` every mode is a scalar first-order
recursion

    z[k+1] = lam z[k] + g[k],    lam = exp(-s dt),

whose input term ``g`` is exact for heat inputs held constant over a step
(zero-order hold) and air temperatures varying linearly between samples
(first-order hold). All modes and all steps are advanced at once by a
doubling scan (log2(n) vectorised passes), so there is no Python loop over
samples or nodes.
"""

from dataclasses import dataclass

import numpy as np
from scipy import linalg
from scipy.signal import lfilter

# ModalSystem keeps the step gains of this many step lengths.
GAIN_CACHE_SIZE = 64


def _scan(lam, y):
    """In-place inclusive scan ``y[t] += lam y[t-1]`` along axis -2 (doubling)."""
    power = np.array(lam, dtype=float)
    n = y.shape[-2]
    shift = 1
    while shift < n:
        y[..., shift:, :] += power * y[..., : n - shift, :]
        power = power * power
        shift *= 2


def linear_recurrence(lam, g, x0, block=64):
    """All states of ``x[k+1] = lam * x[k] + g[k]`` for k = 0..n-1, vectorised.

    Parameters
    ----------
    lam : ndarray of shape (m,)
        Per-column decay factors, ``0 <= lam <= 1`` for a stable system.
    g : ndarray of shape (n, m)
        Input terms.
    x0 : ndarray of shape (m,)
        Initial state.
    block : int, default=64
        Block length of the two-level scan.

    Returns
    -------
    x : ndarray of shape (n + 1, m)
        ``x[0] = x0`` and the ``n`` following states.

    Notes
    -----
    A two-level doubling (Hillis-Steele) scan: the steps are cut into blocks,
    every block is scanned at once in ``log2(block)`` vectorised passes, the
    states at the block boundaries follow from a scan over the (few) block
    ends, and one more pass adds each block's starting state. The result is
    the exact recursion up to rounding, with no Python loop over time.
    """
    g = np.asarray(g, dtype=float)
    lam = np.asarray(lam, dtype=float)
    n, m = g.shape
    x = np.empty((n + 1, m))
    x[0] = x0
    if n == 0:
        return x
    if n <= block:
        x[1:] = g
        x[1] += lam * x0
        _scan(lam, x[1:])
        return x
    nb = -(-n // block)
    y = np.zeros((nb, block, m))
    y.reshape(nb * block, m)[:n] = g
    _scan(lam, y)
    lam_pows = lam[None, :] ** np.arange(1, block + 1)[:, None]  # (block, m)
    starts = linear_recurrence(lam_pows[-1], y[:, -1, :], x0, block)  # (nb+1, m)
    y += lam_pows[None, :, :] * starts[:-1, None, :]
    x[1:] = y.reshape(nb * block, m)[:n]
    return x


def _hold_gains(s, dt):
    """Exact per-mode gains for zero- and first-order hold inputs.

    For ``dz/dt = -s z + u(t)`` over one step of length ``dt``:
    ``phi0 = int_0^dt e^{-s(dt-t)} dt`` (input held constant) and
    ``phi1 = int_0^dt e^{-s(dt-t)} t/dt dt`` (weight of the end value when the
    input varies linearly), computed without cancellation for small ``s dt``.
    """
    x = s * dt
    one_minus_lam = -np.expm1(-x)
    small = x < 1e-5
    xs = np.where(small, 1.0, x)
    phi0 = np.where(
        small, dt * (1 - x / 2 + x * x / 6), one_minus_lam / np.where(small, 1.0, s)
    )
    phi1 = np.where(
        small,
        dt * (0.5 - x / 6 + x * x / 24),
        dt * (xs - one_minus_lam) / (xs * xs),
    )
    return phi0, phi1


@dataclass(frozen=True)
class ModalSystem:
    """Eigen-decomposition of one operating point of a thermal network.

    Attributes
    ----------
    rates : ndarray of shape (n_modes,)
        Decay rates ``s`` (1/s) of the modes; time constants are ``1 / s``.
    to_modal : ndarray of shape (n_modes, n_nodes)
        ``P = V^T D^-1``: maps a heat-input vector (W) to modal inputs.
    from_modal : ndarray of shape (n_nodes, n_modes)
        ``D^-1 V``: maps modal states back to node temperatures.
    state_to_modal : ndarray of shape (n_modes, n_nodes)
        ``V^T D``: maps node temperatures to modal states.
    """

    rates: np.ndarray
    to_modal: np.ndarray
    from_modal: np.ndarray
    state_to_modal: np.ndarray

    @classmethod
    def from_network(cls, capacity, conductance):
        """Decompose ``C^-1 (L + H)`` given capacities and a conductance matrix.

        Parameters
        ----------
        capacity : ndarray of shape (n_nodes,)
            Heat capacities (J/K), all positive.
        conductance : ndarray of shape (n_nodes, n_nodes)
            Symmetric ``L + H`` (W/K): the Laplacian of the node-to-node
            conductances plus the convection of each node on the diagonal.
        """
        d = np.sqrt(capacity)
        S = conductance / d[:, None] / d[None, :]
        rates, V = linalg.eigh(S)
        if rates[0] <= 0:
            raise ValueError(
                "The thermal network has no path to the air (a zero decay rate): "
                "give at least one node a positive convection to ambient."
            )
        return cls(
            rates=rates,
            to_modal=V.T / d[None, :],
            from_modal=V / d[:, None],
            state_to_modal=V.T * d[None, :],
        )

    def _gains(self, dt):
        """Per-mode decay and hold gains for a step ``dt``, cached for the
        first ``GAIN_CACHE_SIZE`` step lengths (the sample periods; the odd
        steps to segment starts between samples would grow it without
        end)."""
        cache = self.__dict__.setdefault("_gain_cache", {})
        if dt in cache:
            return cache[dt]
        phi0, phi1 = _hold_gains(self.rates, dt)
        gains = (np.exp(-self.rates * dt), phi0, phi1)
        if len(cache) < GAIN_CACHE_SIZE:
            cache[dt] = gains
        return gains

    @property
    def time_constants(self):
        """Time constants ``1 / s`` of the modes, in seconds (slowest last)."""
        return 1.0 / self.rates[::-1]

    def step(self, T0, heat, air_conductance, air, dt, heat_nodes=None):
        """Advance node temperatures over ``n`` steps of length ``dt``.

        Several responses of the same network (for example the parts of a
        response driven by different heat sources) advance together when
        the arguments carry a leading axis of ``k`` parts: one recursion
        over ``k`` times the modes.

        Parameters
        ----------
        T0 : ndarray of shape (n_nodes,) or (k, n_nodes)
            Temperatures at the start.
        heat : ndarray of shape (n, n_heated) or (k, n, n_heated)
            Heat input (W) held constant over each step, into the nodes
            ``heat_nodes`` (default: every node, in order).
        air_conductance : ndarray of shape (n_nodes,)
            Convection ``h A`` (W/K) of each node to the driving air.
        air : ndarray of shape (n + 1,) or (k, n + 1)
            Driving air temperature at the step boundaries, linear in between.
        dt : float
            Step length (s).

        Returns
        -------
        T : ndarray of shape (n + 1, n_nodes) or (n + 1, k, n_nodes)
        """
        T0 = np.asarray(T0, dtype=float)
        single = T0.ndim == 1
        T0, heat, air = np.atleast_2d(T0), np.asarray(heat), np.asarray(air)
        if single:
            heat, air = heat[None], air[None]
        lam, phi0, phi1 = self._gains(dt)
        p_air = self.to_modal @ air_conductance  # (n_modes,)
        P = self.to_modal if heat_nodes is None else self.to_modal[:, heat_nodes]
        g = heat @ (P.T * phi0[None, :])  # (k, n, n_modes)
        g += air[:, :-1, None] * (p_air * (phi0 - phi1))
        g += air[:, 1:, None] * (p_air * phi1)
        k, n, modes = g.shape
        z = linear_recurrence(
            np.tile(lam, k),
            g.transpose(1, 0, 2).reshape(n, k * modes),
            (T0 @ self.state_to_modal.T).ravel(),
        )
        T = (z.reshape((n + 1) * k, modes) @ self.from_modal.T).reshape(n + 1, k, -1)
        return T[:, 0] if single else T


def first_order_lag(x, tau, dt):
    """Readings that follow ``x`` through a first-order lag ``tau dy/dt = x - y``.

    Exact for ``x`` varying linearly between samples (first-order hold); one
    ``scipy.signal.lfilter`` call filters every column at once. The output
    starts at ``x[0]``.

    Parameters
    ----------
    x : ndarray of shape (n, m)
    tau : float
        Time constant (s).
    dt : float
        Sample period (s).
    """
    rate = 1.0 / tau
    lam = float(np.exp(-rate * dt))
    phi0, phi1 = _hold_gains(np.array([rate]), dt)
    b = [rate * float(phi1[0]), rate * float(phi0[0] - phi1[0])]
    # y[k] = lam y[k-1] + b0 x[k] + b1 x[k-1], started in equilibrium at x[0].
    zi = ((lam + b[1]) * x[0])[None, :]
    y, _ = lfilter(b, [1.0, -lam], x[1:], axis=0, zi=zi)
    return np.vstack([x[:1], y])
