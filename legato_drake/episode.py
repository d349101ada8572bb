"""Running one episode: build, randomize, simulate until success or time-out, report."""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from pydrake.geometry import Meshcat, MeshcatParams
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import EventStatus

from legato_drake import conventions
from legato_drake.diagram import LegatoDiagram, build_diagram
from legato_drake.files import atomic_write_text
from legato_drake.scenario import Scenario
from legato_drake.systems.tracking_monitor import TrackingStats

DONE_GRACE = 2.0
"""Seconds the episode goes on after the controller is done, for the scene to settle."""


@dataclass
class EpisodeResult:
    """What one episode did: the verdict, why, and how fast and how accurately."""

    embodiment: str
    task: str
    controller: str
    seed: int
    success: bool
    reason: str
    """Empty on success; else the first failed condition of the success predicate."""
    success_time: float | None
    """Seconds after the controller took over when success first held (None if never)."""
    episode_time: float
    """Simulated seconds after homing."""
    sim_time: float
    """Simulated seconds in all, homing included."""
    wall_time: float
    real_time_factor: float
    tracking: TrackingStats
    metrics: dict[str, float] = field(default_factory=dict)

    def to_dict(self) -> dict:
        """A JSON-friendly dict."""
        return dataclasses.asdict(self)


def make_meshcat() -> Meshcat:
    """A headless Meshcat on a free port (safe in parallel tests)."""
    return Meshcat(MeshcatParams(port=0))


def initialize(built: LegatoDiagram, simulator: Simulator) -> None:
    """Applies the scenario's seeded randomization to the simulator's context."""
    context = simulator.get_mutable_context()
    plant_context = built.plant.GetMyMutableContextFromRoot(context)
    built.task.set_initial_state(built.plant, plant_context,
                                 np.random.default_rng(built.scenario.seed))


def run_episode(scenario: Scenario, html: str | Path | None = None) -> EpisodeResult:
    """Builds and simulates one episode of ``scenario`` (``build_diagram`` validates it);
    with ``html``, writes a Meshcat replay there (atomically)."""
    meshcat = make_meshcat() if html is not None or scenario.recording.meshcat else None
    built = build_diagram(scenario, meshcat)
    _, result = simulate(built)
    if html is not None:
        atomic_write_text(Path(html), built.meshcat.StaticHtml())
    return result


def simulate(built: LegatoDiagram) -> tuple[Simulator, EpisodeResult]:
    """Simulates a built diagram from its scenario's seeded initial state until success (if
    ``stop_on_success``), the controller is done, or the time limit; records the Meshcat
    replay if the diagram has a visualizer. Returns the simulator (its context holds the
    final state) and the result."""
    run = EpisodeRun(built)
    run.advance_to(run.t_end)
    return run.simulator, run.result()


class EpisodeRun:
    """One episode in progress: the simulator of a built diagram from its scenario's seeded
    initial state, advanced by the caller (``advance_to``) until it ends: success (with
    ``stop_on_success``), the controller done for ``DONE_GRACE`` seconds, or the time limit
    ``t_end`` (homing plus the scenario's duration). ``simulate`` runs one to its end in one
    call; a Gymnasium environment (``legato_drake.envs``) advances it one policy step at a
    time. Either way ``result()`` is the episode's verdict, from the same code."""

    def __init__(self, built: LegatoDiagram):
        self.built = built
        scenario = built.scenario
        self.simulator = Simulator(built.diagram)
        initialize(built, self.simulator)
        self.t_end = conventions.HOMING_DURATION + scenario.duration
        self.stopped = ""
        """Why the episode stopped before ``t_end`` ("success", "controller done"), or
        empty."""
        self._success_port = built.success.GetOutputPort("success")
        self._done_port = built.controller.GetOutputPort("done")
        root = self.simulator.get_context()
        # The monitor runs at every step: the subsystems' contexts are looked up once.
        self._success_context = built.success.GetMyContextFromRoot(root)
        self._controller_context = built.controller.GetMyContextFromRoot(root)
        self._done_since: list[float] = []
        self._result: EpisodeResult | None = None
        self.simulator.set_monitor(self._monitor)
        if built.visualizer is not None:
            built.visualizer.StartRecording(False)
        start = time.perf_counter()
        self.simulator.Initialize()
        self.wall_time = time.perf_counter() - start

    @property
    def context(self):
        """The diagram's context (the episode's state now)."""
        return self.simulator.get_context()

    @property
    def time(self) -> float:
        """Simulated seconds so far, homing included."""
        return self.context.get_time()

    @property
    def ended(self) -> bool:
        """Whether the episode is over (stopped early, or at its time limit)."""
        return bool(self.stopped) or self.time >= self.t_end - 1e-9

    def success_now(self) -> bool:
        """Whether the task's success predicate holds now."""
        return self._success_port.Eval(self._success_context)[0] > 0.5

    def _monitor(self, root_context) -> EventStatus:
        built, scenario = self.built, self.built.scenario
        if scenario.stop_on_success and self._success_port.Eval(self._success_context)[0] > 0.5:
            self.stopped = "success"
            return EventStatus.ReachedTermination(built.diagram, "success")
        if self._done_port.Eval(self._controller_context)[0] > 0.5:
            if not self._done_since:
                self._done_since.append(root_context.get_time())
            elif root_context.get_time() - self._done_since[0] >= DONE_GRACE:
                self.stopped = "controller done"
                return EventStatus.ReachedTermination(built.diagram, "controller done")
        return EventStatus.Succeeded()

    def advance_to(self, t: float) -> None:
        """Simulates until ``t`` (at most ``t_end``), or until the episode stops."""
        if self.ended:
            return
        start = time.perf_counter()
        self.simulator.AdvanceTo(min(t, self.t_end))
        self.wall_time += time.perf_counter() - start

    def result(self) -> EpisodeResult:
        """The episode's result as it stands (publishes the Meshcat recording, once)."""
        built, scenario, context = self.built, self.built.scenario, self.context
        if built.visualizer is not None and self._result is None:
            built.visualizer.StopRecording()
            built.visualizer.PublishRecording()
        success_context = built.success.GetMyContextFromRoot(context)
        report = built.success.evaluate(success_context)
        first = built.success.GetOutputPort("first_success_time").Eval(success_context)[0]
        if scenario.stop_on_success and not np.isnan(first) and not report.success:
            # Stopped on the monitor's latched verdict; the state is a physics step later,
            # where a borderline condition (the object's speed) may read differently. The
            # verdict counts.
            report = dataclasses.replace(report, success=True, reason="")
        stats = TrackingStats.from_vector(built.tracking.GetOutputPort("stats").Eval(
            built.tracking.GetMyContextFromRoot(context)))
        sim_time, wall = context.get_time(), self.wall_time
        self._result = EpisodeResult(
            embodiment=scenario.embodiment, task=scenario.task, controller=scenario.controller,
            seed=scenario.seed, success=report.success, reason=report.reason,
            success_time=None if np.isnan(first)
            else float(first - conventions.HOMING_DURATION),
            episode_time=max(sim_time - conventions.HOMING_DURATION, 0.0), sim_time=sim_time,
            wall_time=wall, real_time_factor=sim_time / wall if wall > 0 else float("inf"),
            tracking=stats, metrics=report.metrics)
        return self._result
