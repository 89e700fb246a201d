"""The sequence `viewslam record` reads: a folder, bag, scenario or name, or the built-in demo."""

from collections.abc import Iterator
from dataclasses import dataclass, fields
from pathlib import Path

from ..dataset.sources import NotABag, RgbdSequence, open_source
from ..errors import InputError

DEMO_SCENARIO = "360_kidnap"
DEMO_FRAMES = 240
DEMO_RESOLUTION = (320, 240)
GROUNDTRUTH_FLAG = "--groundtruth"


@dataclass(frozen=True)
class BagTopics:
    """A ROS bag's topics to read (None: found by type, see :func:`~viewer_slam.dataset.rosbag.open_bag`)."""

    rgb_topic: str | None = None
    depth_topic: str | None = None
    camera_info_topic: str | None = None
    groundtruth_topic: str | None = None

    def given(self) -> Iterator[str]:
        """The flags of the topics that are set, in the order of the command line."""
        for topic in fields(self):
            if getattr(self, topic.name) is not None:
                yield "--" + topic.name.replace("_", "-")


def open_input(
    sequence: str | None,
    bag: BagTopics = BagTopics(),
    groundtruth: Path | None = None,
    first: int | None = None,
    progress: bool = False,
) -> RgbdSequence:
    """The sequence to record; the ``bag`` topics and ``groundtruth`` file (set ones only) for a ROS
    bag, an error naming the flag for anything else.

    A synthetic scenario (or the demo) is rendered up to frame ``first`` only, showing
    ``progress`` on stderr.
    """
    if sequence is None:
        from ..dataset.synth import cached_scenario  # the scene renderer loads only for the demo

        source: str | Path = cached_scenario(
            DEMO_SCENARIO, frames=DEMO_FRAMES, resolution=DEMO_RESOLUTION, first=first, progress=progress
        )
    else:
        source = sequence
    options = {
        "rgb_topic": bag.rgb_topic,
        "depth_topic": bag.depth_topic,
        "camera_info_topic": bag.camera_info_topic,
        "groundtruth": groundtruth,
        "groundtruth_topic": bag.groundtruth_topic,
    }  # the command line's order
    try:
        return open_source(source, bag=options, first=first, progress=progress)
    except NotABag as error:
        flag = "--" + error.option.replace("_", "-")
        alone = " (without SEQUENCE, --groundtruth records trajectory files alone)" if flag == GROUNDTRUTH_FLAG else ""
        raise InputError(f"{flag}: only for a ROS bag, and {sequence or 'the demo'} is not one{alone}") from None
