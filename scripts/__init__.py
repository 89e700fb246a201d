"""The repository's own upkeep, each module run from its root as ``python -m scripts.NAME``:
the documents' figures (``doc_figures``), the output schemas' page (``schema_docs``), the
reference runs' digests (``reference_runs``) and the viewer screenshots (``viewer_screenshots``).
The shell scripts beside them set up, lock, lint and test the project."""
