"""viewslam: a 3D visual debugger and benchmark for RGB-D SLAM.

Every command is a library function returning a typed result (docs/api.md)::

    from viewer_slam import benchmark, diff, evaluate, record, study, synth

They load on first use, so importing the package (and ``viewslam --help``) stays light.
"""

import importlib
from typing import TYPE_CHECKING, Any

from .code_paths import hold

hold()  # before anything of the package imports NumPy: see code_paths

from .version import __version__  # noqa: E402

# Each command's function, by the module it lives in. record, benchmark and study are also the
# names of their packages, which are made callable (commands.py).
COMMANDS = {
    "evaluate": "viewer_slam.runs.evaluate_command",
    "record": "viewer_slam.record.command",
    "benchmark": "viewer_slam.benchmark.command",
    "study": "viewer_slam.study.command",
    "diff": "viewer_slam.record.diff",
    "synth": "viewer_slam.dataset.synth.command",
}
CALLABLE_PACKAGES = ("record", "benchmark", "study")
__all__ = ["__version__", *COMMANDS]

if TYPE_CHECKING:
    from .benchmark.command import benchmark as benchmark
    from .dataset.synth.command import synth as synth
    from .record.command import record as record
    from .record.diff import diff as diff
    from .runs.evaluate_command import evaluate as evaluate
    from .study.command import study as study


def __getattr__(name: str) -> Any:
    if name not in COMMANDS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    if name in CALLABLE_PACKAGES:
        return importlib.import_module(f"{__name__}.{name}")
    return getattr(importlib.import_module(COMMANDS[name]), name)
