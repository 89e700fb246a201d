"""The sequence `viewslam record` reads: a folder, bag, scenario or name, or the built-in demo."""

from pathlib import Path

from ..dataset.sources import NotABag, RgbdSequence, open_source
from ..errors import InputError
from .options import BAG_FLAGS, BagOptions

DEMO_SCENARIO = "360_kidnap"
DEMO_FRAMES = 240
DEMO_RESOLUTION = (320, 240)


def open_input(sequence: str | None, bag: BagOptions | None = None, first: int | None = None,
               progress: bool = False) -> RgbdSequence:
    """The sequence to record; ``bag`` options (set ones only) for a ROS bag, an error for anything else.

    A synthetic scenario (or the demo) is rendered up to frame ``first`` only, showing
    ``progress`` on stderr.
    """
    if sequence is None:
        from ..dataset.synth import cached_scenario  # the scene renderer loads only for the demo

        source: str | Path = cached_scenario(DEMO_SCENARIO, frames=DEMO_FRAMES, resolution=DEMO_RESOLUTION,
                                             first=first, progress=progress)
    else:
        source = sequence
    try:
        return open_source(source, bag=bag, first=first, progress=progress)
    except NotABag as error:
        flag = BAG_FLAGS[error.option]
        alone = " (without SEQUENCE, --groundtruth records trajectory files alone)" if flag == "--groundtruth" else ""
        raise InputError(f"{flag}: only for a ROS bag, and {sequence or 'the demo'} is not one{alone}") from None
