"""Where things live in a recording and how they are coloured.

The recorder writes to these paths and the blueprint views them, so both read them from
here. ``world`` is the groundtruth frame; ``world/<pipeline>`` is a pipeline's map frame.
"""

GROUNDTRUTH = "world/groundtruth"
CAMERA_IMAGE = "camera/image"

GROUNDTRUTH_COLOR = (170, 170, 170)
PIPELINE_COLORS = {"rgbdslam": (255, 140, 0), "rtabmap": (40, 150, 255)}
FALLBACK_COLORS = ((200, 80, 220), (60, 200, 120), (230, 200, 40))
COLOR_NAMES = {(255, 140, 0): "orange", (40, 150, 255): "blue", (200, 80, 220): "purple", (60, 200, 120): "green",
               (230, 200, 40): "yellow"}
ACCEPTED_COLOR = (40, 220, 90)
REJECTED_COLOR = (150, 40, 40)
INLIER_COLOR = (40, 220, 90)
OUTLIER_COLOR = (235, 50, 50)
STATUS_COLORS = {"initialising": (150, 150, 150), "ok": (40, 220, 90), "relocalised": (255, 200, 0),
                 "lost": (235, 50, 50)}
LOST_COLOR = STATUS_COLORS["lost"]


def pipeline_color(name: str, position: int = 0) -> tuple[int, int, int]:
    return PIPELINE_COLORS.get(name, FALLBACK_COLORS[position % len(FALLBACK_COLORS)])


def world(name: str) -> str:
    """The pipeline's map frame; its transform to ``world`` is the final ATE alignment."""
    return f"world/{name}"


def camera(name: str) -> str:
    return f"world/{name}/camera"


def trajectory(name: str) -> str:
    return f"world/{name}/trajectory"


def odometry(name: str) -> str:
    return f"world/{name}/odometry"


def keyframes(name: str) -> str:
    return f"world/{name}/keyframes"


def latest_keyframe(name: str) -> str:
    return f"world/{name}/keyframes/latest"


def loop_closures(name: str) -> str:
    return f"world/{name}/loop_closures"


def rejected_loop_closures(name: str) -> str:
    return f"world/{name}/loop_closures/rejected"


def map_cloud(name: str) -> str:
    return f"world/{name}/map"


def matches(name: str) -> str:
    return f"{name}/matches"


def metric(name: str, series: str) -> str:
    return f"metrics/{name}/{series}"


def text_log(name: str) -> str:
    return f"log/{name}"
