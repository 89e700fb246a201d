"""Where things live in a recording.

The recorder writes to these paths and the blueprint views them, so both read them from
here (their colours are in :mod:`viewer_slam.palette`). ``world`` is the groundtruth frame;
``world/<pipeline>`` is a pipeline's map frame.
"""

GROUNDTRUTH = "world/groundtruth"
CAMERA_IMAGE = "camera/image"
SUMMARY = "summary"  # a recording of trajectory files: the scores as Markdown


def world(name: str) -> str:
    """The pipeline's map frame; its transform to ``world`` is the final ATE alignment."""
    return f"world/{name}"


def camera(name: str) -> str:
    return f"world/{name}/camera"


def lost_label(name: str) -> str:
    """A labelled point at the last pose while the pipeline is lost."""
    return f"world/{name}/lost"


def trajectory(name: str) -> str:
    return f"world/{name}/trajectory"


def poses(name: str) -> str:
    """A trajectory file's poses, each coloured by its error."""
    return f"world/{name}/poses"


def correspondences(name: str) -> str:
    """A line from each pose of a trajectory file to the groundtruth pose it was scored against."""
    return f"world/{name}/correspondences"


def odometry(name: str) -> str:
    return f"world/{name}/odometry"


def keyframes(name: str) -> str:
    return f"world/{name}/keyframes"


def latest_keyframe(name: str) -> str:
    return f"world/{name}/keyframes/latest"


def loop_closures(name: str) -> str:
    return f"world/{name}/loop_closures"


def recent_loop_closures(name: str) -> str:
    """The accepted loop closures of the last few seconds (drawn bright)."""
    return f"world/{name}/loop_closures/recent"


def rejected_loop_closures(name: str) -> str:
    return f"world/{name}/loop_closures/rejected"


def edges(name: str, kind: str) -> str:
    """Accepted graph edges of one kind other than loop closures (``sequential``, ``local``)."""
    return f"world/{name}/edges/{kind}"


def map_cloud(name: str) -> str:
    return f"world/{name}/map"


def matches(name: str) -> str:
    return f"{name}/matches"


def metric(name: str, series: str) -> str:
    return f"metrics/{name}/{series}"


def text_log(name: str) -> str:
    return f"log/{name}"
