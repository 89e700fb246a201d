"""The lab: the measurements behind the figures of README.md and docs/, as thin clients of the library.

Each module is a script run from the repository's root, ``python -m benchmarks.NAME --help``.
They set parameters and run pipelines the library's own way (:mod:`benchmarks.lab`: ``--param``
and ``--config`` as ``viewslam record`` reads them, runs through the run service) and write
the figure blocks of the documents through :mod:`benchmarks.figures`. The package sits above
``viewer_slam.cli``: it imports the library, and nothing in the library imports it.
"""
