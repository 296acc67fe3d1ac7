"""Gaze-selected targets: a head-to-gaze model and the target estimate it gives (003 section 5.2, Paper III).

003 Paper III estimates where the operator looks from the orientation of the head (an IMU on
the head, 003 section 3.1) with "a simple linear model of the head-to-gaze estimation
function, carefully calibrated according to the individual operator". Here:

* :class:`HeadGazeModel`: gaze angles ``g = A h + b`` from head angles ``h`` (yaw, pitch, rad),
  ``A`` (2, 2), ``b`` (2,), and the covariance ``S_g`` (2, 2) of the residual, fitted per
  operator by least squares on calibration samples (:meth:`HeadGazeModel.calibrate`);
* :func:`gaze_angles` / :func:`gaze_point`: the gaze direction from the operator's eye point
  ``e`` (base frame) and where it meets the height ``z = z_look`` of what the operator looks at
  (the top of a log pile, the bunk); the crane's tip target lies ``tip_above_m`` above it
  (the grapple hangs below the tip);
* :func:`estimate_target`: the target estimate ``p_est`` and its covariance
  ``S_p = J S_g J^T`` (first-order propagation through the ray-plane intersection, ``J`` its
  Jacobian with respect to the gaze angles), which 003 eq. 5.7's error-aware selection takes
  (``covariance`` of :meth:`motionlib.library.selection.SelectionIndex.select`).

Angles: yaw about z from +x, pitch above the horizontal (negative looking down), rad.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..checks import check_points, check_scalar, check_vector
from ..errors import InputError


@dataclass(frozen=True)
class HeadGazeModel:
    """Linear head-to-gaze model ``g = A h + b`` with residual covariance (Paper III).

    Attributes
    ----------
    A : ndarray, shape (2, 2)
        Gain from head angles (yaw, pitch) to gaze angles (dimensionless).
    b : ndarray, shape (2,)
        Offset (rad).
    residual_cov : ndarray, shape (2, 2)
        Covariance (rad^2) of ``g - (A h + b)`` on the calibration samples.
    n_samples : int
        Calibration samples it was fitted on.
    """

    A: np.ndarray  # noqa: N815 (the model's symbol)
    b: np.ndarray
    residual_cov: np.ndarray
    n_samples: int

    def gaze(self, head: Any) -> np.ndarray:
        """Gaze angles (n, 2) (rad) for head angles (n, 2) or (2,) (rad)."""
        h = check_points(head, "head", dim=2)
        return h @ self.A.T + self.b

    @classmethod
    def calibrate(cls, head: Any, gaze: Any) -> HeadGazeModel:
        """Fit the model to calibration pairs: the operator looks at known targets, the head is measured.

        The gaze angles of the calibration targets are known exactly and the measured head angles
        scatter, so the least-squares fit is of the head on the gaze, ``h = C g + d`` (unbiased for
        noise on the head), inverted to ``g = A h + b`` with ``A = C^-1``, ``b = -C^-1 d``. The
        residual covariance is that of the head residuals mapped into gaze angles, ``A S_h A^T``
        (``S_h`` divided by ``n - 3``: three parameters per row).

        Parameters
        ----------
        head : array_like, shape (n, 2)
            Measured head angles (yaw, pitch) (rad) while the operator looks at the targets, n >= 4.
        gaze : array_like, shape (n, 2)
            The gaze angles to those targets (rad), e.g. :func:`gaze_angles` of the eye and the targets.

        Raises
        ------
        InputError
            Fewer than four pairs, or targets that do not spread in both angles (``C`` singular).
        """
        h = check_points(head, "head", dim=2)
        g = check_points(gaze, "gaze", dim=2)
        if h.shape != g.shape or h.shape[0] < 4:
            raise InputError(f"head, gaze: expected equal shapes (n, 2) with n >= 4, got {h.shape} and {g.shape}")
        design = np.column_stack([g, np.ones(g.shape[0])])
        coef, _, rank, _ = np.linalg.lstsq(design, h, rcond=None)  # (3, 2): h = g C^T + d
        c_mat, d = coef[:2].T, coef[2]
        if rank < 3 or abs(np.linalg.det(c_mat)) < 1e-9:
            raise InputError("gaze: the calibration targets must spread in yaw and in pitch")
        a_mat = np.linalg.inv(c_mat)
        residual = h - design @ coef
        cov_h = residual.T @ residual / (h.shape[0] - 3)
        return cls(a_mat, -a_mat @ d, a_mat @ cov_h @ a_mat.T, int(h.shape[0]))


def gaze_angles(eye: Any, points: Any) -> np.ndarray:
    """Yaw and pitch (n, 2) (rad) of the directions from ``eye`` (3,) to ``points`` (n, 3) (m)."""
    e = check_vector(eye, 3, "eye")
    d = check_points(points, "points") - e
    return np.column_stack([np.arctan2(d[:, 1], d[:, 0]), np.arctan2(d[:, 2], np.hypot(d[:, 0], d[:, 1]))])


def gaze_point(eye: Any, angles: Any, z_look: float) -> tuple[np.ndarray, np.ndarray]:
    """Where gaze directions meet the plane ``z = z_look``, and the Jacobian of that point.

    Parameters
    ----------
    eye : array_like, shape (3,)
        The operator's eye point (m, base frame), above ``z_look``.
    angles : array_like, shape (n, 2)
        Gaze yaw and pitch (rad); the pitch must look down (< 0).
    z_look : float
        Height (m) of what the operator looks at.

    Returns
    -------
    points : ndarray, shape (n, 3)
        ``e + r (cos yaw, sin yaw, 0) + (0, 0, z_look - e_z)``, ``r = (e_z - z_look) / tan(-pitch)``.
    jacobian : ndarray, shape (n, 3, 2)
        ``d point / d (yaw, pitch)`` (m/rad), in closed form.
    """
    e = check_vector(eye, 3, "eye")
    a = check_points(angles, "angles", dim=2)
    z = check_scalar(z_look, "z_look", lt=float(e[2]))
    yaw, pitch = a[:, 0], a[:, 1]
    if np.any(pitch >= -1e-6):
        raise InputError("angles: the gaze must look down to meet the height looked at (pitch < 0)")
    height = e[2] - z
    r = height / np.tan(-pitch)
    c, s = np.cos(yaw), np.sin(yaw)
    points = np.column_stack([e[0] + r * c, e[1] + r * s, np.full(r.shape, z)])
    dr_dpitch = height / np.sin(pitch) ** 2  # d/dpitch of height / tan(-pitch)
    jac = np.zeros((a.shape[0], 3, 2))
    jac[:, 0, 0], jac[:, 1, 0] = -r * s, r * c
    jac[:, 0, 1], jac[:, 1, 1] = dr_dpitch * c, dr_dpitch * s
    return points, jac


@dataclass(frozen=True)
class GazeEstimate:
    """A target estimated from the head orientation.

    Attributes
    ----------
    p_est : ndarray, shape (3,)
        Estimated target (m, base frame).
    covariance : ndarray, shape (3, 3)
        Covariance (m^2) of its error, ``J S_g J^T`` (rank 2: the estimate lies on the working plane).
    gaze : ndarray, shape (2,)
        The gaze angles (rad) it came from.
    """

    p_est: np.ndarray
    covariance: np.ndarray
    gaze: np.ndarray


def estimate_target(
    model: HeadGazeModel, head: Any, eye: Any, z_look: float, tip_above_m: float = 0.0
) -> GazeEstimate:
    """The tip target estimate and its covariance from one head orientation (see the module docstring).

    Parameters
    ----------
    model : HeadGazeModel
    head : array_like, shape (2,)
        Measured head yaw and pitch (rad).
    eye : array_like, shape (3,)
        The operator's eye point (m, base frame).
    z_look : float
        Height (m) of what the operator looks at (a pile's top, the bunk).
    tip_above_m : float
        The tip target's height above the point looked at (m): where the tip is when the grapple works there.
    """
    g = model.gaze(check_vector(head, 2, "head"))
    points, jac = gaze_point(eye, g, z_look)
    j = jac[0]
    p_est = points[0] + np.array([0.0, 0.0, check_scalar(tip_above_m, "tip_above_m")])
    return GazeEstimate(p_est, j @ model.residual_cov @ j.T, g[0])
