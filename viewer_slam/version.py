"""The installed package's version, which reports and cached results are stamped with."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("viewer-slam")
except PackageNotFoundError:  # running from a source tree that was not installed
    __version__ = "0.0.0"
