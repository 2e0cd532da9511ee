"""Closed-form solution of the 1D impact problem of SPEC section 2.

Bar [0, 1], E = rho = 1 (wave speed 1), clamped at x = 1, contact with the rigid
obstacle at x = 0 (outward normal n = -1, no gap), u0(x) = 1/2 - x/2, v0 = 0
(Dabaghi-Petrov-Pousin-Renard 2016). The solution is periodic with period 3 and, with
tau = t mod 3, of d'Alembert form

    u(x, t) = F(x - tau) + G(x + tau),

    F(s) = (1 - s)/4  on [0, 1],     G(s) = (1 - s)/4  on [0, 2],
           (1 + s)/4  on [-1, 0],           (s - 3)/4  on [2, 3],
          -(1 + s)/4  on [-3, -1],          (3 - s)/4  on [3, 4].

Phases at x = 0: flight t in [0, 1) (u = 1/2 - t/2, v = -1/2), contact [1, 2]
(u = 0, sigma = u_x = -1/2), release (2, 3] (u = (t - 2)/2, v = +1/2); the energy
1/2 int (u_t^2 + u_x^2) dx is 1/8 at all times. tests/test_exact_1d.py checks all of
this (wave equation, boundary and initial data, Signorini conditions) numerically.

The trace of a 1D run reports u_n = u.n = -u(0, t), v_n = -u_t(0, t) and the contact
stress p_n (Nitsche's [P_1(u)]_-, which tends to sigma_n = u_x(0, t) n.n = u_x(0, t)).
"""

from __future__ import annotations

import numpy as np

#: Period of the motion.
PERIOD = 3.0
#: Energy per unit cross-section, for all t.
ENERGY = 1.0 / 8.0


def _F(s):
    s = np.asarray(s, dtype=float)
    return np.where(s >= 0.0, (1.0 - s) / 4.0,
                    np.where(s >= -1.0, (1.0 + s) / 4.0, -(1.0 + s) / 4.0))


def _dF(s):
    s = np.asarray(s, dtype=float)
    return np.where(s > 0.0, -0.25, np.where(s > -1.0, 0.25, -0.25))


def _G(s):
    s = np.asarray(s, dtype=float)
    return np.where(s <= 2.0, (1.0 - s) / 4.0,
                    np.where(s <= 3.0, (s - 3.0) / 4.0, (3.0 - s) / 4.0))


def _dG(s):
    s = np.asarray(s, dtype=float)
    return np.where(s < 2.0, -0.25, np.where(s < 3.0, 0.25, -0.25))


def _tau(t):
    return np.mod(np.asarray(t, dtype=float), PERIOD)


def u(x, t):
    """Displacement u(x, t) (broadcasts x against t)."""
    tau = _tau(t)
    return _F(np.asarray(x) - tau) + _G(np.asarray(x) + tau)


def u_t(x, t):
    """Velocity. Exact away from the characteristics through the kinks of F and G; on
    them (e.g. x = t in the flight phase) it is one of the two one-sided values."""
    tau = _tau(t)
    return -_dF(np.asarray(x) - tau) + _dG(np.asarray(x) + tau)


def u_x(x, t):
    """Strain = stress sigma = E u_x (E = 1); one-sided on the kinks, like u_t."""
    tau = _tau(t)
    return _dF(np.asarray(x) - tau) + _dG(np.asarray(x) + tau)


def u_n(t):
    """Normal displacement at the contact point: u.n with n = -1."""
    return -u(0.0, t)


def v_n(t):
    """Normal velocity at the contact point."""
    return -u_t(0.0, t)


def sigma_n(t):
    """Normal contact stress at x = 0: -1/2 in contact (t mod 3 in (1, 2)), 0 otherwise."""
    return u_x(0.0, t)


def phase(t):
    """'flight' (t mod 3 < 1), 'contact' ([1, 2]) or 'release' (> 2), per time."""
    tau = _tau(t)
    return np.where(tau < 1.0, "flight", np.where(tau <= 2.0, "contact", "release"))
