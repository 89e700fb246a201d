"""viewslam: a 3D visual debugger and benchmark for RGB-D SLAM."""

from importlib.metadata import PackageNotFoundError, version

from .code_paths import hold

hold()  # before anything of the package imports NumPy: see code_paths

try:
    __version__ = version("viewer-slam")
except PackageNotFoundError:  # running from a source tree that was not installed
    __version__ = "0.0.0"
