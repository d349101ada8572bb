"""What runs many episodes: the layer above the diagram.

Each module builds scenarios, turns them into typed job records and runs them through one
``legato_drake.executor.Executor`` (serial or worker processes), writing results as they come:

- ``episodes``: independent episodes with optional Meshcat replays (``demo``);
- ``collect``: a demonstration dataset, atomic and resumable (``collect``);
- ``evaluate``: closed-loop trials of a trained policy, resumable results and plots
  (``evaluate``);
- ``selection``: a training run's checkpoint chosen by rollouts on validation seeds
  (``select``);
- ``retarget``: Abstract demonstrations replayed open-loop on every robot
  (``retarget-benchmark``);
- ``pose_streams``: synthetic pose-stream recordings made by the scripted demonstrator.

Layers import downward only: pipelines use ``diagram``, ``episode``, ``scenario``, the
registries, ``data`` (formats) and ``learning`` (checkpoints); nothing below imports them.
"""
