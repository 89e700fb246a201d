"""The seed study replayed from the runs its author published (``viewslam study``)."""

from ..commands import make_callable

make_callable(__name__, f"{__name__}.command", "study")  # `viewer_slam.study(...)` runs the command: see commands.py
