"""`viewslam record`: the runs over a sequence, or trajectory files alone, into a Rerun recording with
the report and trajectories beside it; and `viewslam diff`, two recorded runs compared into one.

This layer joins the run service (:mod:`viewer_slam.runs`) and the comparison
(:mod:`viewer_slam.comparison`) to the Rerun adapter (:mod:`viewer_slam.rerun_adapter`): the options are checked, the outputs staged and the runs scored
here, while everything written into the recording is the adapter's.
"""

from ..commands import make_callable

make_callable(__name__, f"{__name__}.command", "record")  # `viewer_slam.record(...)` runs the command: see commands.py
