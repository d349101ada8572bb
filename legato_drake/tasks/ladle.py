"""Ladle reorganization: move the ladle from the pot into the utensil case (SPEC §6).

Scene (table top at z 0.625, all draws uniform, objects dropped and settled while the robot
homes), as in the SPEC:

* the stove at x 0.6, y U(0.18, 0.42), the pot on it;
* the ladle (handle 0.04 x 0.04 x 0.08, stick 0.02 x 0.02 x 0.12, scoop 0.06 x 0.06 x 0.03
  in a row, 0.2 kg, friction 2) dropped into the pot: its origin (the end of the handle) at
  the stove's top-face centre + (-0.12, -0.12, 0.2), pointing at the pot's axis (yaw 45°)
  and tilted 45° down, lifted 12 mm more so that the scoop starts just clear of the pot's
  floor. It settles with the scoop on the pot's floor, the stick on the rim and the handle
  out of the pot, towards the robot;
* the utensil case (interior 0.16 x 0.26, walls 0.04 high) at x 0.5625, y U(-0.42, -0.38),
  yaw 0.5π ± π/8 (its long side then runs roughly along the world's x axis).

Success predicate (all on the plant state, thresholds are class attributes):

* the ladle's centre of mass is over the case's interior footprint, at least ``min_inset``
  (1 cm) inside its walls;
* the centre of mass is within ``height_band`` (-1 cm to +6 cm) of the case's floor (the
  ladle lies in the case: flat, 2 cm, or leaning on a wall);
* the ladle is released: both fingers are open wider than the handle plus 8 mm;
* the ladle has settled: its speed is under ``max_speed`` (5 cm/s).

Scripted expert: grasp the handle end-on (the gripper's approach axis along the ladle, its
pitch the ladle's tilt clipped to 35-50°), lift it off the rim, pull it out of the pot along
its axis, turn it along the case's long side, lower the scoop to just above the case's floor
so that the centre of mass is over the case, release (the handle drops between the opened
fingers), back off.
"""

from __future__ import annotations

import numpy as np
from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import Context

from legato_drake.dimensions import CASE_INTERIOR, LADLE_HANDLE, LADLE_SCOOP, LADLE_STICK
from legato_drake.tasks.base import (
    DROP,
    SuccessReport,
    Task,
    Waypoint,
    add_stove_and_pot,
    add_table,
    body_speed,
    finger_opening,
    on_table_check,
    place_stove_and_pot,
    release_check,
    uniform,
    verdict,
)

TABLE_HEIGHT = 0.625
CASE_INTERIOR_HALF = (CASE_INTERIOR[0] / 2, CASE_INTERIOR[1] / 2)
"""Half sizes of the case's interior footprint in its frame (x, y)."""
LADLE_HALF_WIDTH = LADLE_HANDLE[1] / 2
"""Half the handle's width (what the pads close on)."""
LADLE_LENGTH = LADLE_HANDLE[0] + LADLE_STICK[0] + LADLE_SCOOP[0]
LADLE_SCOOP_HALF = LADLE_SCOOP[1] / 2
"""Half the scoop's width and height bound the ladle's cross-section."""

STOVE_X = 0.6
STOVE_Y = (0.18, 0.42)
LADLE_OFFSET = (-0.12, -0.12, 0.2)
LADLE_LIFT = 0.012
CASE_X = 0.5625
CASE_Y = (-0.42, -0.38)
CASE_YAW = (0.5 * np.pi - np.pi / 8, 0.5 * np.pi + np.pi / 8)


class LadleTask(Task):
    """Ladle reorganization."""

    name = "ladle"
    description = "move the ladle from the pot into the utensil case"

    min_inset = 0.01
    height_band = (-0.01, 0.06)
    release_margin = 0.008
    max_speed = 0.05

    def add_to_plant(self, plant: MultibodyPlant, parser: Parser) -> None:
        add_table(plant, parser, TABLE_HEIGHT)
        self.stove, self.pot = add_stove_and_pot(plant, parser)
        (ladle,) = parser.AddModels(url="package://legato_drake/ladle.sdf")
        (case,) = parser.AddModels(url="package://legato_drake/case.sdf")
        self.ladle = plant.GetBodyByName("ladle", ladle)
        self.case = plant.GetBodyByName("case", case)
        self.ladle_handle = plant.GetFrameByName("ladle_handle", ladle)
        self.case_floor = plant.GetFrameByName("case_floor", case)

    def set_initial_state(self, plant: MultibodyPlant, context: Context,
                          rng: np.random.Generator) -> None:
        stove_xy = np.array([STOVE_X, uniform(rng, *STOVE_Y)])
        top = place_stove_and_pot(plant, context, self.stove, self.pot, stove_xy, TABLE_HEIGHT)
        plant.SetFreeBodyPose(context, self.ladle, RigidTransform(
            RollPitchYaw(0.0, np.pi / 4, np.pi / 4),
            top + LADLE_OFFSET + [0.0, 0.0, LADLE_LIFT]))
        plant.SetFreeBodyPose(context, self.case, RigidTransform(
            RollPitchYaw(0.0, 0.0, uniform(rng, *CASE_YAW)),
            [CASE_X, uniform(rng, *CASE_Y), TABLE_HEIGHT + DROP]))

    def ladle_com(self, plant: MultibodyPlant, context: Context) -> np.ndarray:
        """The ladle's centre of mass in the world."""
        return plant.EvalBodyPoseInWorld(context, self.ladle) @ \
            self.ladle.CalcCenterOfMassInBodyFrame(context)

    def evaluate(self, plant: MultibodyPlant, context: Context) -> SuccessReport:
        X_WF = self.case_floor.CalcPoseInWorld(context)
        p_WL = self.ladle_com(plant, context)
        x, y, z = X_WF.inverse() @ p_WL
        inset = float(min(CASE_INTERIOR_HALF[0] - abs(x), CASE_INTERIOR_HALF[1] - abs(y)))
        fingers = finger_opening(plant, context)
        speed = body_speed(plant, context, self.ladle)
        metrics = dict(inset=inset, case_x=float(x), case_y=float(y), com_height=float(z),
                       finger_opening=fingers, ladle_speed=speed)
        low, high = self.height_band
        checks = [
            on_table_check("ladle", float(p_WL[2]), TABLE_HEIGHT),
            (inset >= self.min_inset,
             f"ladle's centre of mass {inset * 100:.1f} cm inside the case's walls (min "
             f"{self.min_inset * 100:.0f} cm; negative = outside)"),
            (low <= z <= high,
             f"ladle's centre of mass {z * 100:+.1f} cm above the case's floor (allowed "
             f"{low * 100:+.1f} to {high * 100:+.1f} cm)"),
            release_check("ladle", fingers, LADLE_HALF_WIDTH, self.release_margin),
            (speed <= self.max_speed, f"ladle still moving at {speed:.2f} m/s"),
        ]
        return verdict(checks, metrics)

    def plan_demonstration(self, plant: MultibodyPlant, context: Context,
                           rng: np.random.Generator) -> list[Waypoint]:
        X_WL = plant.EvalBodyPoseInWorld(context, self.ladle)
        X_WH = self.ladle_handle.CalcPoseInWorld(context)
        X_WF = self.case_floor.CalcPoseInWorld(context)

        # Grasp the handle end-on: the approach axis along the ladle, pitched as it is tilted.
        axis = X_WL.rotation().matrix()[:, 0]
        yaw = np.arctan2(axis[1], axis[0]) + np.radians(uniform(rng, -4.0, 4.0))
        tilt = np.degrees(np.arctan2(-axis[2], np.linalg.norm(axis[:2])))
        pitch = np.radians(np.clip(tilt + uniform(rng, -3.0, 3.0), 35.0, 50.0))
        R_grasp = RotationMatrix.MakeZRotation(yaw) @ RotationMatrix.MakeYRotation(pitch)
        approach = R_grasp.matrix()[:, 0]
        p_grasp = X_WH.translation() + uniform(rng, -0.008, 0.008) * axis
        X_WG = RigidTransform(R_grasp, p_grasp)
        X_GL = X_WG.inverse() @ X_WL
        p_pregrasp = p_grasp - uniform(rng, 0.08, 0.11) * approach + [0.0, 0.0, 0.01]

        # Lift off the rim, then pull the ladle out of the pot along its axis and up.
        p_lift = p_grasp + [0.0, 0.0, uniform(rng, 0.03, 0.04)]
        p_out = p_lift - uniform(rng, 0.20, 0.23) * approach + [0.0, 0.0, 0.06]

        # Over the case: the gripper along the case's long side (its y), the centre of mass a
        # little beyond the case's centre (the handle's fall brings it back), the ladle's
        # lowest point 1 cm above the floor.
        long_side = X_WF.rotation().matrix()[:, 1]
        place_yaw = np.arctan2(long_side[1], long_side[0])
        place_yaw = (place_yaw + np.pi / 2) % np.pi - np.pi / 2  # the direction closest to +x
        place_yaw += np.radians(uniform(rng, -4.0, 4.0))
        R_place = RotationMatrix.MakeZRotation(place_yaw) @ RotationMatrix.MakeYRotation(pitch)
        forward = R_place.matrix()[:, 0] * [1.0, 1.0, 0.0]
        forward /= np.linalg.norm(forward)
        com_target = X_WF @ [uniform(rng, -0.01, 0.01), 0.0, 0.0] \
            + uniform(rng, 0.02, 0.04) * forward
        p_LC = self.ladle.CalcCenterOfMassInBodyFrame(context)
        p_place = com_target - R_place @ (X_GL @ p_LC)
        corners = [X_GL @ [x, y, z] for x in (0.0, LADLE_LENGTH)
                   for y in (-LADLE_SCOOP_HALF, LADLE_SCOOP_HALF)
                   for z in (-LADLE_SCOOP_HALF, LADLE_SCOOP_HALF)]
        lowest = min((R_place @ c)[2] for c in corners)
        p_place[2] = X_WF.translation()[2] + 0.01 - lowest
        p_above = p_place + [0.0, 0.0, uniform(rng, 0.06, 0.09)]
        p_retreat = p_place - 0.08 * R_place.matrix()[:, 0] + [0.0, 0.0, 0.08]

        speed = uniform(rng, 0.12, 0.18)
        return [
            Waypoint(RigidTransform(R_grasp, p_pregrasp), grasp=False, speed=speed),
            Waypoint(X_WG, grasp=False, speed=0.06, profile="stop"),
            Waypoint(X_WG, grasp=True, hold=0.9),
            Waypoint(RigidTransform(R_grasp, p_lift), grasp=True, speed=0.05),
            Waypoint(RigidTransform(R_grasp, p_out), grasp=True, speed=0.08),
            Waypoint(RigidTransform(R_place, p_above), grasp=True, speed=speed),
            Waypoint(RigidTransform(R_place, p_place), grasp=True, speed=0.05, profile="stop"),
            Waypoint(RigidTransform(R_place, p_place), grasp=False, hold=0.8),
            Waypoint(RigidTransform(R_place, p_retreat), grasp=False, speed=0.1),
        ]
