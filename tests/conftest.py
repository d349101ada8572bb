"""Shared fixtures: small plants and diagrams built once per test session."""

from __future__ import annotations

import pytest
from pydrake.systems.framework import DiagramBuilder

from legato_drake.diagram import build_plant
from legato_drake.scenario import Scenario


@pytest.fixture(scope="session")
def panda_plant():
    """(plant, scene_graph, robot handles, task) of the Panda lid scene."""
    return build_plant(Scenario(embodiment="panda", task="lid"), DiagramBuilder())


@pytest.fixture(scope="session")
def abstract_plant():
    """(plant, scene_graph, robot handles, task) of the Abstract lid scene."""
    return build_plant(Scenario(embodiment="abstract", task="lid"), DiagramBuilder())
