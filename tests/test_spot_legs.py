"""SpotLegIK keeps Spot's feet on their fixed world points, checked with the plant's kinematics.

The plant is ``models/spot.urdf`` with ``spot_world_anchor`` welded at the world origin; the
system is evaluated alone in its own context (FixValue on its input port).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import JacobianWrtVariable

from legato_drake.embodiments.spot import BODY_JOINTS, LEG_JOINTS
from legato_drake.systems.spot_legs import (
    LEGS,
    NOMINAL_BODY_POSE,
    SPOT_LEG_GEOMETRY,
    SpotLegIK,
    body_rotation,
    leg_ik,
    standing_foot_positions,
    standing_leg_angles,
)

BODY_LOWER = np.array([-0.3, -0.1, 0.3, -math.pi / 16, -math.pi / 16, -math.pi / 16])
BODY_UPPER = np.array([-0.1, 0.1, 0.5, math.pi / 16, math.pi / 16, math.pi / 16])
"""The body joints' limits (SPEC §4: +-0.1 m, +-pi/16 around the nominal pose)."""
GEOMETRY = SPOT_LEG_GEOMETRY


class Spot:
    """The Spot plant, with helpers to pose it and read its feet."""

    def __init__(self):
        self.plant = MultibodyPlant(time_step=0.0)
        parser = Parser(self.plant)
        parser.SetStrictParsing()
        parser.package_map().Add("legato_drake", str(Path(__file__).parents[1] / "models"))
        parser.AddModels(url="package://legato_drake/spot.urdf")
        self.plant.WeldFrames(self.plant.world_frame(),
                              self.plant.GetFrameByName("spot_world_anchor"))
        self.plant.Finalize()
        self.context = self.plant.CreateDefaultContext()
        self.body_q = [self.plant.GetJointByName(n).position_start() for n in BODY_JOINTS]
        self.leg_q = [self.plant.GetJointByName(n).position_start() for n in LEG_JOINTS]
        self.body_v = [self.plant.GetJointByName(n).velocity_start() for n in BODY_JOINTS]
        self.leg_v = [self.plant.GetJointByName(n).velocity_start() for n in LEG_JOINTS]
        self.feet = [self.plant.GetFrameByName(f"{leg}_foot") for leg in LEGS]

    def set(self, body: np.ndarray, legs: np.ndarray) -> None:
        q = self.plant.GetPositions(self.context)
        q[self.body_q], q[self.leg_q] = body, legs
        self.plant.SetPositions(self.context, q)

    def foot_positions(self) -> np.ndarray:
        return np.array([f.CalcPoseInWorld(self.context).translation() for f in self.feet])

    def foot_velocities(self, body_v: np.ndarray, leg_v: np.ndarray) -> np.ndarray:
        v = np.zeros(self.plant.num_velocities())
        v[self.body_v], v[self.leg_v] = body_v, leg_v
        world = self.plant.world_frame()
        return np.array([
            self.plant.CalcJacobianTranslationalVelocity(
                self.context, JacobianWrtVariable.kV, f, np.zeros(3), world, world) @ v
            for f in self.feet])


@pytest.fixture(scope="module")
def spot() -> Spot:
    return Spot()


def evaluate(system: SpotLegIK, body_state) -> np.ndarray:
    """The system's output for ``body_state``, from its own context."""
    context = system.CreateDefaultContext()
    system.get_body_desired_state_input_port().FixValue(context, np.asarray(body_state, float))
    return system.get_leg_desired_state_output_port().Eval(context)


def random_body_poses(n: int, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).uniform(BODY_LOWER, BODY_UPPER, size=(n, 6))


def interior(q: np.ndarray, margin: float = 1e-9) -> bool:
    return bool(np.all(q > GEOMETRY.lower_limits + margin)
                and np.all(q < GEOMETRY.upper_limits - margin))


def test_ports_and_feedthrough():
    system = SpotLegIK()
    assert system.num_input_ports() == 1 and system.num_output_ports() == 1
    assert system.get_input_port(0).get_name() == "body_desired_state"
    assert system.get_input_port(0).size() == 12
    assert system.get_output_port(0).get_name() == "leg_desired_state"
    assert system.get_output_port(0).size() == 24
    assert system.HasDirectFeedthrough(0, 0)
    context = system.CreateDefaultContext()
    assert context.num_discrete_state_groups() == 0 and context.num_continuous_states() == 0


def test_body_rotation_matches_the_virtual_joint_chain(spot):
    for pose in random_body_poses(5, seed=3):
        spot.set(pose, standing_leg_angles())
        X = spot.plant.GetBodyByName("body").EvalPoseInWorld(spot.context)
        np.testing.assert_allclose(X.translation(), pose[:3], atol=1e-12)
        np.testing.assert_allclose(X.rotation().matrix(), body_rotation(*pose[3:]), atol=1e-12)


def test_standing_posture(spot):
    """Nominal body (-0.2, 0, 0.4): feet below the hip-y joints on z = 0, hip_x = 0."""
    feet = standing_foot_positions()
    expected = [[-0.2 + fx * 0.29785, fy * (0.055 + 0.110945), 0.0]
                for fx, fy in ((1, 1), (1, -1), (-1, 1), (-1, -1))]
    np.testing.assert_allclose(feet, expected, atol=1e-12)
    q = standing_leg_angles()
    assert interior(q, margin=0.2)
    np.testing.assert_allclose(q[0::3], 0.0, atol=1e-12)  # hip_x
    np.testing.assert_allclose(q[1::3], q[1], atol=1e-12)  # same thigh angle on every leg
    np.testing.assert_allclose(q[2::3], q[2], atol=1e-12)  # same knee angle on every leg
    spot.set(NOMINAL_BODY_POSE, q)
    np.testing.assert_allclose(spot.foot_positions(), feet, atol=1e-12)
    np.testing.assert_allclose(evaluate(SpotLegIK(), [*NOMINAL_BODY_POSE, *np.zeros(6)]),
                               [*q, *np.zeros(12)], atol=1e-12)


def test_feet_stay_on_their_world_points(spot):
    """Random body poses within the SPEC bounds: the output puts every foot frame on its
    fixed world point. (Only the extreme combined corners of the bounds, about 1e-4 of the
    box, need more hip abduction than the +-0.7854 limit; see the next test.)"""
    feet = standing_foot_positions() + [[0.02, 0.01, 0.0], [-0.01, -0.02, 0.0],
                                        [0.0, 0.015, 0.0], [0.01, 0.0, 0.0]]
    system = SpotLegIK(feet)
    np.testing.assert_allclose(system.foot_positions, feet)
    for pose in [NOMINAL_BODY_POSE, BODY_LOWER, BODY_UPPER, *random_body_poses(40)]:
        out = evaluate(system, [*pose, *np.zeros(6)])
        assert interior(out[:12]), pose
        np.testing.assert_allclose(out[12:], 0.0, atol=1e-12)
        spot.set(pose, out[:12])
        np.testing.assert_allclose(spot.foot_positions(), feet, atol=1e-6, err_msg=str(pose))


def test_bounds_corner_beyond_hip_abduction_is_clamped(spot):
    """Body low, shifted right, rolled left and yawed: the front hips would need more than
    0.7854 rad of abduction. The output clamps them and stays within 6 cm of the feet."""
    feet = standing_foot_positions()
    pose = np.array([-0.3, -0.1, 0.3, -math.pi / 16, math.pi / 16, -math.pi / 16])
    q = leg_ik(pose, feet)
    assert np.all(np.isfinite(q))
    assert np.all(q >= GEOMETRY.lower_limits) and np.all(q <= GEOMETRY.upper_limits)
    assert q[0] == pytest.approx(0.7854) and q[3] == pytest.approx(0.7854)
    spot.set(pose, q)
    error = np.linalg.norm(spot.foot_positions() - feet, axis=1)
    assert np.all(error[2:] < 1e-6) and np.all(error < 0.06)
    # Such corners are rare: over a random sample of the bounds, nearly all poses are exact.
    exact = sum(interior(leg_ik(p, feet)) for p in random_body_poses(2000, seed=7))
    assert exact >= 1995


def test_velocities_keep_the_feet_still(spot):
    """The output velocities, with the body velocities, give the feet (almost) no velocity."""
    system = SpotLegIK()
    rng = np.random.default_rng(1)
    inner = 0.5 * (BODY_LOWER + BODY_UPPER)
    half = 0.25 * (BODY_UPPER - BODY_LOWER)
    for _ in range(10):
        pose = rng.uniform(inner - half, inner + half)
        body_v = rng.uniform(-1.0, 1.0, size=6)
        out = evaluate(system, [*pose, *body_v])
        spot.set(pose, out[:12])
        foot_v = spot.foot_velocities(body_v, out[12:])
        assert np.max(np.abs(foot_v)) < 2e-3, foot_v
        # The body alone would drag the feet at up to about 1 m/s.
        assert np.max(np.abs(spot.foot_velocities(body_v, np.zeros(12)))) > 0.1


@pytest.mark.parametrize(
    "body_state",
    [
        [5.0, 3.0, 2.0, 0.0, 0.0, 0.0, *np.zeros(6)],  # far above: legs stretch
        [-0.2, 0.0, -0.5, 0.0, 0.0, 0.0, *np.zeros(6)],  # below the ground: legs fold
        [-0.2, 0.0, 0.4, 3.0, -3.0, 3.0, *np.ones(6) * 50.0],  # upside down, fast
        [*standing_foot_positions()[0], 0.0, 0.0, 0.0, *np.zeros(6)],  # body on a foot
        [math.nan, 0.0, 0.4, 0.0, 0.0, 0.0, *np.zeros(6)],
        [-0.2, 0.0, 0.4, 0.0, 0.0, 0.0, math.inf, *np.zeros(5)],
        [1e300, -1e300, 1e300, 1e300, 0.0, 0.0, *np.full(6, 1e300)],
    ],
)
def test_unreachable_inputs_give_finite_in_limit_outputs(body_state):
    out = evaluate(SpotLegIK(), body_state)
    assert np.all(np.isfinite(out))
    assert np.all(out[:12] >= GEOMETRY.lower_limits)
    assert np.all(out[:12] <= GEOMETRY.upper_limits)


def test_stretching_toward_an_unreachable_foot(spot):
    """Body 0.9 m high: every leg is straight (knee at its limit) and points at its foot."""
    feet = standing_foot_positions()
    pose = np.array([-0.2, 0.0, 0.9, 0.0, 0.0, 0.0])
    q = leg_ik(pose, feet)
    np.testing.assert_allclose(q[2::3], GEOMETRY.knee_limits[1])
    spot.set(pose, q)
    for i, leg in enumerate(LEGS):
        hip = spot.plant.GetFrameByName(f"{leg}_upper_leg").CalcPoseInWorld(spot.context)
        to_foot = spot.foot_positions()[i] - hip.translation()
        to_target = feet[i] - hip.translation()
        cosine = to_foot @ to_target / np.linalg.norm(to_foot) / np.linalg.norm(to_target)
        assert cosine > 1.0 - 1e-9


def test_invalid_construction():
    with pytest.raises(ValueError):
        SpotLegIK(np.zeros((3, 3)))
    with pytest.raises(ValueError):
        SpotLegIK(period=0.0)
