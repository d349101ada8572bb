"""Demonstration datasets: recording, the HDF5 layout, collection, inspection, training data.

Modules: ``layout`` (names, format version, validation), ``writer`` (HDF5 writing),
``collect`` (parallel, resumable collection), ``pose_stream`` (recorded 6-DoF pose streams),
``inspect`` (summaries and plots), ``torch_dataset`` (a torch ``Dataset`` of sequences),
``synthetic`` (tiny simulation-free episodes for tests).
The layout is documented in docs/data_format.md.
"""
