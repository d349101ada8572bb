"""Robots are data, systems are systems, and each model dimension has one source.

That ``embodiments/`` and ``systems/`` never import each other, and that the neutral modules
they share import neither, is ``tests/test_import_graph.py``'s; here: ``dimensions.py``, which
the model generator reads too, imports nothing of the package, and the code holds no second
copy of a generated dimension.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def imported_modules(path: Path) -> set[str]:
    """Every module an import statement in ``path`` names (absolute imports only: the
    package uses no relative ones)."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            names |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom):
            assert node.level == 0, f"{path}: relative import"
            names |= {node.module, *(f"{node.module}.{a.name}" for a in node.names)}
    return names


def test_dimensions_import_nothing_of_the_package():
    allowed = {"__future__", "__future__.annotations", "math"}
    assert imported_modules(ROOT / "legato_drake" / "dimensions.py") <= allowed


def test_the_generator_reads_the_shared_dimensions():
    """``models/generate_models.py`` takes the dimensions the code needs from
    ``legato_drake.dimensions`` (and nothing else of the package)."""
    imported = imported_modules(ROOT / "models" / "generate_models.py")
    package = {m for m in imported if m.startswith("legato_drake")}
    assert "legato_drake.dimensions" in package
    assert all(m.startswith("legato_drake.dimensions") for m in package), package


def test_the_code_reads_the_dimensions_the_models_are_made_of():
    """Tasks, systems and embodiments hold no second copy of the generated dimensions."""
    from legato_drake import conventions, dimensions
    from legato_drake.embodiments.abstract import ABSTRACT
    from legato_drake.embodiments.gr1 import GR1
    from legato_drake.leg_kinematics import NOMINAL_BODY_POSE, SPOT_LEG_GEOMETRY
    from legato_drake.tasks import base, cup, ladle, lid

    assert conventions.GRIPPER_OPEN == dimensions.GRIPPER_OPEN
    assert ABSTRACT.X_mount_gripper.translation()[0] == -dimensions.GRIPPER_TCP_X
    assert GR1.base_pose.translation()[2] == dimensions.GR1_PELVIS_HEIGHT
    assert SPOT_LEG_GEOMETRY.hip_x_offset == dimensions.SPOT_HIP_X
    assert SPOT_LEG_GEOMETRY.knee_limits == dimensions.SPOT_KNEE_LIMITS
    assert tuple(NOMINAL_BODY_POSE) == dimensions.SPOT_NOMINAL_BODY_POSE
    assert dimensions.STOVE_SIZE[2] == 2 * base.STOVE_HALF_HEIGHT
    assert 2 * lid.LID_HALF_THICKNESS == dimensions.LID_THICKNESS
    assert dimensions.LID_HANDLE_BAR[0] == 2 * lid.HANDLE_HALF_WIDTH
    assert (2 * ladle.CASE_INTERIOR_HALF[0], 2 * ladle.CASE_INTERIOR_HALF[1]) == \
        dimensions.CASE_INTERIOR
    assert cup.SHELF_FLOOR == dimensions.SHELF_BOARD
    assert dimensions.CUP_HANDLE[1] == 2 * cup.HANDLE_HALF_WIDTH
