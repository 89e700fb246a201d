"""The scripted run recorded once per test module, for the tests that read its recording."""

from scripted_circle import recorded, scripted_pipelines, tum_folder  # noqa: F401  (fixtures)
