"""Model dimensions that the model files and the code both depend on: one source for each.

``models/generate_models.py`` writes the model files (``models/*.sdf``, ``*.urdf``) from these
numbers, and the tasks, systems and embodiments that need the same numbers (a pot's height, a
handle's width, Spot's leg geometry) read them here, so a dimension changed here and
regenerated changes everywhere at once. Plain numbers only (this module imports nothing but
``math``), so that the generator, the robot side and the tests can all read it.

Lengths in metres, angles in radians; frames as in the model files' comments.
"""

from __future__ import annotations

import math

# ---------------------------------------------------------------------------- the gripper

GRIPPER_OPEN = 0.052
"""Finger joint position (m from the centre plane) when fully open: pad gap 0.104 m (the
finger joints' upper limit)."""
GRIPPER_TCP_X = 0.14
"""The TCP frame ``gripper_tcp`` lies this far along the gripper base's +x (approach)."""

# ---------------------------------------------------------------------------- Spot

SPOT_LEG_SIGNS = {"fl": (1.0, 1.0), "fr": (1.0, -1.0), "hl": (-1.0, 1.0), "hr": (-1.0, -1.0)}
"""Leg name: (front +1 / hind -1, left +1 / right -1), in the legs' order."""
SPOT_HIP_X = (0.29785, 0.055, 0.0)
"""The front-left hip-x joint in the body frame; the other legs mirror x and/or y."""
SPOT_HIP_Y = 0.110945
"""Lateral offset of the hip-y joint from the hip-x joint (+y left legs, -y right)."""
SPOT_KNEE = (0.025, -0.3205)
"""The knee joint (x, z) in the upper-leg frame."""
SPOT_LOWER_LEG = 0.33
"""The foot's distance along the lower leg's -z from the knee."""
SPOT_NOMINAL_BODY_POSE = (-0.2, 0.0, 0.4, 0.0, 0.0, 0.0)
"""Spot's home body pose [x, y, z, roll, pitch, yaw] in the world (SPEC §4): the centre of its
virtual body joints' ranges."""
SPOT_BODY_HALF_RANGE = (0.1, 0.1, 0.1, math.pi / 16, math.pi / 16, math.pi / 16)
"""Half-ranges of the virtual body joints around ``SPOT_NOMINAL_BODY_POSE``."""
SPOT_HIP_X_LIMITS = (-0.7854, 0.7854)
SPOT_HIP_Y_LIMITS = (-0.8988, 2.2951)
SPOT_KNEE_LIMITS = (-2.7929, -0.2471)
"""Joint limits of each leg's hip_x, hip_y and knee."""

# ---------------------------------------------------------------------------- GR-1

GR1_PELVIS_HEIGHT = 0.88
"""Height of GR-1's pelvis frame above the soles of its (held) legs: where it is welded."""

# ---------------------------------------------------------------------------- scene objects

STOVE_SIZE = (0.30, 0.24, 0.02)
"""The stove box (origin at its centre)."""
POT_HEIGHT = 0.1
"""Height of the pot's rim plane (frame ``pot_rim``) above the pot's origin (bottom face)."""
LID_RADIUS = 0.11
LID_THICKNESS = 0.01
"""The lid's disc (origin at its centre)."""
LID_HANDLE_BAR = (0.02, 0.08, 0.02)
"""The lid's bar handle (x, y, z size): the fingers close across its 0.02 x width."""
LID_HANDLE_Z = 0.045
"""Height of the bar's centre (frame ``lid_handle``) above the lid's origin."""

SHELF_SIZE = (0.5, 0.3, 0.43)
"""Outer size of the open shelf: width (x), depth (y), height (z); origin at the centre of the
bottom face, open front towards +y."""
SHELF_SIDE = 0.02
SHELF_BACK = 0.02
SHELF_BOARD = 0.035
"""Side and back walls 0.02 thick, top and bottom boards 0.035: interior 0.46 x 0.28 x 0.36."""

CUP_R_OUT = 0.08
CUP_R_IN = 0.07
CUP_H = 0.16
CUP_BASE = 0.01
CUP_HANDLE = (0.024, 0.014, 0.10)
"""The cup's handle bar: radial depth, tangential width (what the pads pinch), height."""
CUP_HANDLE_R = 0.115
"""Radius (from the cup's axis) of the handle bar's centre."""
CUP_HANDLE_Z = 0.085

LADLE_HANDLE = (0.08, 0.04, 0.04)
LADLE_STICK = (0.12, 0.02, 0.02)
LADLE_SCOOP = (0.06, 0.06, 0.03)
"""The ladle's three boxes in a row along +x from its origin (the handle's end)."""

CASE_INTERIOR = (0.16, 0.26)
"""The utensil case's interior footprint (x, y)."""
CASE_WALL = 0.01
CASE_BASE = 0.01
CASE_WALL_H = 0.04
"""Wall thickness, floor thickness and wall height above the floor."""
