"""The one way into data: a SEQUENCE argument, whatever it names, opened as a sequence.

A SEQUENCE is a TUM folder, a ROS bag (a ``.bag`` file or a ROS 2 bag folder), a synthetic
scenario or a catalogue name (:mod:`.catalog` says where a name's data lives). Every command
opens its sequences here, so they all accept the same forms and refuse the rest alike.
"""

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ..errors import InputError
from .catalog import resolve_sequence
from .rosbag import BagSequence, is_bag, open_bag
from .tum import TumSequence, open_tum

RgbdSequence = TumSequence | BagSequence


class NotABag(InputError):
    """A ROS bag option (``option``, an :func:`~.rosbag.open_bag` keyword) given for a source that is no bag."""

    def __init__(self, option: str, source: str | Path):
        super().__init__(f"{option}: only for a ROS bag, and {source} is not one")
        self.option = option


def open_source(
    spec: str | Path,
    *,
    frames: int | None = None,
    resolution: tuple[int, int] = (640, 480),
    seed: int = 0,
    first: int | None = None,
    progress: bool = False,
    bag: Mapping[str, Any] | None = None,
) -> RgbdSequence:
    """The sequence ``spec`` names (see the module docstring); an :class:`InputError` naming it otherwise.

    ``frames``, ``resolution`` and ``seed`` size a synthetic scenario (generated once into the
    cache), ``first`` the frames of it that will be read (only those are rendered), ``progress``
    shows the rendering on stderr; ``bag`` holds :func:`~.rosbag.open_bag`'s topic and groundtruth options, of which
    the ones set apply to a bag only (:class:`NotABag` for any other source).
    """
    path = resolve_sequence(str(spec), frames=frames, resolution=resolution, seed=seed, first=first, progress=progress)
    options = {key: value for key, value in (bag or {}).items() if value is not None}
    if is_bag(path):
        return open_bag(path, **options)
    if options:
        raise NotABag(next(iter(options)), spec)
    return open_tum(path)
