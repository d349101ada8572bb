"""``legato-drake experiment``: a whole study from one grid file, resumable, on any backend.

- ``grid``: the grid file (datasets, methods, training, selection, evaluation), typed;
- ``units``: the units of work (trainings, trials) as jobs, keyed by what they depend on;
- ``runner``: collect -> train -> select -> evaluate on an executor, resumable;
- ``report``: the paper-style tables and figures from trial rows.
"""
