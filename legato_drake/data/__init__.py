"""Demonstration datasets, formats only: the HDF5 layout, writing, reading, inspection, pose
streams, training data. Nothing here builds or runs a diagram (collection, which does:
``legato_drake.pipelines.collect``).

Modules: ``layout`` (names, format version, validation), ``writer`` (HDF5 writing),
``pose_stream`` (recorded 6-DoF pose streams), ``derived`` (observations computed from the
stored ones), ``inspect`` (summaries and plots), ``torch_dataset`` (a torch ``Dataset`` of
sequences), ``synthetic`` (tiny simulation-free episodes for tests).
The layout is documented in docs/data_format.md.
"""
