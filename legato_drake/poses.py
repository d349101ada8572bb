"""Pose algebra shared by the controllers, the target integrator and the data pipeline.

A *pose delta* is the 6-vector ``[dx, dy, dz, droll, dpitch, dyaw]`` of the relative transform
``X_prev^-1 X_next`` between two consecutive commanded gripper poses, expressed in the previous
gripper frame, angles as Drake's roll-pitch-yaw (``R = Rz(yaw) Ry(pitch) Rx(roll)``). This is the
policy's action space (SPEC §7).
"""

from __future__ import annotations

import numpy as np
from pydrake.common.eigen_geometry import AngleAxis, Quaternion
from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix


def pose_delta(X_prev: RigidTransform, X_next: RigidTransform) -> np.ndarray:
    """Returns the 6-D delta ``[xyz, rpy]`` of ``X_prev^-1 X_next``."""
    X = X_prev.inverse() @ X_next
    return np.concatenate([X.translation(), RollPitchYaw(X.rotation()).vector()])


def apply_delta(X: RigidTransform, delta: np.ndarray) -> RigidTransform:
    """Returns ``X`` followed by the 6-D pose ``delta`` (expressed in X's own frame)."""
    delta = np.asarray(delta, dtype=float)
    dX = RigidTransform(RollPitchYaw(delta[3:6]), delta[0:3])
    return X @ dX


def rotation_log(R: RotationMatrix) -> np.ndarray:
    """Returns the rotation vector (axis * angle, angle in [0, pi]) of ``R``."""
    aa = R.ToAngleAxis()
    return aa.axis() * aa.angle()


def spatial_error(X: RigidTransform, X_desired: RigidTransform) -> np.ndarray:
    """``[rotvec(R_des R^T); p_des - p]``: the world-frame rotation and translation from ``X``
    to ``X_desired`` (what a velocity IK's tracking gain multiplies)."""
    return np.concatenate([rotation_log(X_desired.rotation() @ X.rotation().inverse()),
                           X_desired.translation() - X.translation()])


def rotation_exp(w: np.ndarray) -> RotationMatrix:
    """Returns the rotation matrix of the rotation vector ``w``."""
    angle = float(np.linalg.norm(w))
    if angle < 1e-12:
        return RotationMatrix()
    return RotationMatrix(AngleAxis(angle, np.asarray(w) / angle))


def interpolate(X0: RigidTransform, X1: RigidTransform, s: float) -> RigidTransform:
    """Returns the pose a fraction ``s`` in [0, 1] of the way from X0 to X1 (lerp + slerp)."""
    q0 = X0.rotation().ToQuaternion()
    q1 = X1.rotation().ToQuaternion()
    q = q0.slerp(s, q1)
    p = (1.0 - s) * X0.translation() + s * X1.translation()
    return RigidTransform(Quaternion(q.wxyz() / np.linalg.norm(q.wxyz())), p)


def pose_error(X_actual: RigidTransform, X_desired: RigidTransform) -> tuple[float, float]:
    """Returns (position error in m, rotation error in rad) between two poses."""
    dp = float(np.linalg.norm(X_desired.translation() - X_actual.translation()))
    R_err = X_actual.rotation().inverse() @ X_desired.rotation()
    return dp, float(R_err.ToAngleAxis().angle())


def pose_to_vector(X: RigidTransform) -> np.ndarray:
    """Packs a pose as ``[x, y, z, qw, qx, qy, qz]`` (for vector-valued state and datasets)."""
    return np.concatenate([X.translation(), X.rotation().ToQuaternion().wxyz()])


def vector_to_pose(v: np.ndarray) -> RigidTransform:
    """Unpacks ``[x, y, z, qw, qx, qy, qz]`` (the quaternion need not be unit length)."""
    q = np.asarray(v[3:7], dtype=float)
    return RigidTransform(Quaternion(q / np.linalg.norm(q)), np.asarray(v[0:3], dtype=float))
