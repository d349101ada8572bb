"""EpisodeRecorder alone (fixed inputs, its own context) and inside the episode diagram."""

from __future__ import annotations

import numpy as np
import pytest
from pydrake.common.value import AbstractValue
from pydrake.systems.analysis import Simulator

from legato_drake import conventions
from legato_drake.diagram import build_diagram
from legato_drake.episode import simulate
from legato_drake.poses import apply_delta, pose_error, pose_to_vector, vector_to_pose
from legato_drake.scenario import Scenario
from legato_drake.systems.episode_recorder import EpisodeRecorder


def _recorder(abstract_plant, images: bool, t_start: float = 0.0):
    plant, _, robot, task = abstract_plant
    recorder = EpisodeRecorder(plant, robot.tcp_frame, images=images, t_start=t_start)
    context = recorder.CreateDefaultContext()
    plant_context = plant.CreateDefaultContext()
    task.set_initial_state(plant, plant_context, np.random.default_rng(0))
    x = plant.GetPositionsAndVelocities(plant_context)
    action = np.array([0.01, 0.0, -0.02, 0.0, 0.1, 0.0, 1.0])
    commanded = pose_to_vector(conventions.START_POSE)
    recorder.get_action_input_port().FixValue(context, action)
    recorder.get_commanded_pose_input_port().FixValue(context, commanded)
    recorder.get_plant_state_input_port().FixValue(context, x)
    for value, port in enumerate(recorder.get_image_input_ports()):
        port.FixValue(context, AbstractValue.Make(
            np.full((128, 128, 1), 10 * (value + 1), dtype=np.uint8)))
    return recorder, context, plant, plant_context, action, commanded


def test_one_sample_per_period_with_the_inputs(abstract_plant):
    recorder, context, plant, plant_context, action, commanded = _recorder(abstract_plant, True)
    Simulator(recorder, context).AdvanceTo(0.35)
    arrays = recorder.log(context).to_arrays()
    np.testing.assert_allclose(arrays["time"], [0.0015, 0.1015, 0.2015, 0.3015], atol=1e-12)
    assert len(recorder.log(context)) == 4
    np.testing.assert_array_equal(arrays["action"], np.tile(action, (4, 1)))
    np.testing.assert_array_equal(arrays["tcp_commanded"], np.tile(commanded, (4, 1)))
    X_WG = abstract_plant[2].tcp_frame.CalcPoseInWorld(plant_context)
    np.testing.assert_allclose(arrays["tcp_measured"][0], pose_to_vector(X_WG))
    assert recorder.object_body_names == ["stove", "pot", "lid"]
    lid = plant.GetBodyByName("lid")
    np.testing.assert_allclose(arrays["object"][0, 14:21],
                               pose_to_vector(plant.EvalBodyPoseInWorld(plant_context, lid)))
    np.testing.assert_allclose(arrays["fingers"][0], [
        plant.GetJointByName(name).GetOnePosition(plant_context)
        for name in conventions.GRIPPER_FINGER_JOINTS])
    assert arrays["state"].shape == (4, plant.num_positions() + plant.num_velocities())
    assert arrays["left_gray"].shape == (4, 128, 128, 1)
    assert arrays["left_gray"].dtype == np.uint8
    assert (arrays["left_gray"] == 10).all() and (arrays["right_gray"] == 20).all()


def test_nothing_before_t_start_and_clear(abstract_plant):
    recorder, context, *_ = _recorder(abstract_plant, False, t_start=0.2)
    assert recorder.get_image_input_ports() == () and not recorder.has_images
    simulator = Simulator(recorder, context)
    simulator.AdvanceTo(0.35)
    arrays = recorder.log(context).to_arrays()
    np.testing.assert_allclose(arrays["time"], [0.2015, 0.3015], atol=1e-12)
    assert "left_gray" not in arrays
    recorder.clear(context)
    assert len(recorder.log(context)) == 0
    simulator.AdvanceTo(0.45)
    assert len(recorder.log(context)) == 1


def test_each_context_has_its_own_log(abstract_plant):
    recorder, context, *_ = _recorder(abstract_plant, False)
    other = recorder.CreateDefaultContext()
    Simulator(recorder, context).AdvanceTo(0.15)
    assert len(recorder.log(context)) == 2 and len(recorder.log(other)) == 0


def test_in_the_episode_diagram():
    """Sample k: the action taken at t_k and the commanded pose before it, so that the
    commanded poses chain through the actions; measured tracks commanded."""
    scenario = Scenario(embodiment="abstract", seed=2, duration=1.0)
    scenario.camera.enabled = False
    built = build_diagram(scenario, record=True)
    simulator, _ = simulate(built)
    arrays = built.recorder.log(built.recorder.GetMyContextFromRoot(
        simulator.get_context())).to_arrays()
    assert len(arrays["time"]) == 10
    assert arrays["time"][0] == pytest.approx(conventions.HOMING_DURATION + 0.0015)
    np.testing.assert_allclose(arrays["tcp_commanded"][0],
                               pose_to_vector(conventions.START_POSE), atol=1e-12)
    for k in range(9):
        X = apply_delta(vector_to_pose(arrays["tcp_commanded"][k]), arrays["action"][k, :6])
        dp, dr = pose_error(X, vector_to_pose(arrays["tcp_commanded"][k + 1]))
        assert dp < 1e-9 and dr < 1e-9
    assert np.abs(arrays["tcp_measured"][:, :3] - arrays["tcp_commanded"][:, :3]).max() < 2e-3
    assert arrays["object"].shape == (10, 21)
