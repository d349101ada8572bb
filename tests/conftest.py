"""Shared fixtures: small plants and diagrams built once per test session."""

from __future__ import annotations

import pytest
from pydrake.systems.framework import DiagramBuilder

from legato_drake.diagram import build_plant
from legato_drake.scenario import Scenario


def _lid_scene(embodiment: str):
    """(plant, scene_graph, robot handles, task) of ``embodiment``'s lid scene."""
    return build_plant(Scenario(embodiment=embodiment, task="lid"), DiagramBuilder())


@pytest.fixture(scope="session")
def panda_plant():
    return _lid_scene("panda")


@pytest.fixture(scope="session")
def abstract_plant():
    return _lid_scene("abstract")


@pytest.fixture(scope="session")
def google_plant():
    return _lid_scene("google")


@pytest.fixture(scope="session")
def gr1_plant():
    return _lid_scene("gr1")
