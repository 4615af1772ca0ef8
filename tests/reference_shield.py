"""A slow, literal numpy transcription of the paper's Sec. III equations, in the world frame.

Only the tests use it: the Rust shield is compared against it. Nothing here is optimised or
shifted beyond what float64 needs for the test inputs.
"""

from __future__ import annotations

import numpy as np


def rot_z(yaw: float) -> np.ndarray:
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def skew(w: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def cbfs_world(points_w, p_r, R, omega, semi_axes):
    """h_i, dh_i/dp_r (N, 3) and dh_i/dt for world points (N, 3): Q_W = R A R^T."""
    a = np.zeros(3)
    a[: len(semi_axes)] = 1.0 / np.asarray(semi_axes, float) ** 2
    A = np.diag(a)
    Q = R @ A @ R.T
    Qdot = R @ (skew(omega) @ A - A @ skew(omega)) @ R.T
    d = points_w - p_r
    h = np.einsum("ni,ij,nj->n", d, Q, d) - 1.0
    grad = -2.0 * d @ Q.T
    dt = np.einsum("ni,ij,nj->n", d, Qdot, d)
    return h, grad, dt


def composite(h, grad, dt, gamma, kappa):
    """H, dH/dp, dH/dt of the soft-min composite (shifted log-sum-exp in float64)."""
    if len(h) == 0:
        return gamma, np.zeros(3), 0.0
    z = -kappa * np.tanh(h / gamma)
    m = z.max()
    w = np.exp(z - m)
    lam = w / w.sum()
    H = -(gamma / kappa) * (m + np.log(w.sum()))
    sech2 = 1.0 / np.cosh(np.minimum(np.abs(h / gamma), 300.0)) ** 2
    coef = lam * sech2
    H = min(H, gamma * np.tanh(h.min() / gamma))
    return H, coef @ grad, float(coef @ dt)


def project(u_nom, g, b, u_max=None):
    """argmin |u - u_nom|^2 s.t. g.u >= b, |u| <= u_max, by bisection on the multiplier."""
    u_nom = np.asarray(u_nom, float)
    lo_b = -np.inf if u_max is None else -np.asarray(u_max, float)
    hi_b = np.inf if u_max is None else np.asarray(u_max, float)

    def u_of(mu):
        return np.clip(u_nom + mu * g, lo_b, hi_b)

    if g @ u_of(0.0) >= b:
        return u_of(0.0), True
    mu_hi = 1.0
    for _ in range(200):
        if g @ u_of(mu_hi) >= b:
            break
        mu_hi *= 2.0
    else:
        return None, False
    mu_lo = 0.0
    for _ in range(200):
        mid = 0.5 * (mu_lo + mu_hi)
        if g @ u_of(mid) >= b:
            mu_hi = mid
        else:
            mu_lo = mid
    return u_of(mu_hi), True


def shield_filter(points_b, u_nom, yaw=0.0, omega=0.0, semi_axes=(0.9, 0.45), gamma=0.9,
                  kappa=8.0, alpha=2.0, crop_radius=3.5, u_max=None, p_r=(0.0, 0.0, 0.0)):
    """The whole planar or 3D composite filter from body-frame points, via the world frame."""
    dim = len(semi_axes)
    pts = np.asarray(points_b, float)
    if crop_radius is not None and len(pts):
        pts = pts[np.linalg.norm(pts[:, :dim], axis=1) <= crop_radius]
    if dim == 2:
        R = rot_z(yaw)
        w = np.array([0.0, 0.0, float(omega)])
        pts3 = np.zeros((len(pts), 3))
        pts3[:, :2] = pts[:, :2]
    else:
        R = np.asarray(yaw, float) if np.ndim(yaw) == 2 else rot_z(yaw)
        w = np.asarray(omega, float) * np.ones(3)
        pts3 = pts
    p_r = np.asarray(p_r, float)
    points_w = pts3 @ R.T + p_r
    h, grad, dt = cbfs_world(points_w, p_r, R, w, semi_axes)
    H, g, dH_dt = composite(h, grad, dt, gamma, kappa)
    g = g[:dim]
    u, feasible = project(u_nom, g, -alpha * H - dH_dt, u_max)
    return {"u": u, "H": H, "grad_p": g, "dH_dt": dH_dt, "h_min": h.min() if len(h) else None,
            "feasible": feasible, "num_points": len(h)}
