"""Every colour viewslam draws with, so a run looks the same in the viewer, the terminal and the charts.

A run (a built-in pipeline, a plugin, an imported estimate) has one colour: the built-in
pipelines their own, every other run a fallback chosen by its position among the runs
shown together, so the same list of runs always gets the same colours.
"""

from typing import NamedTuple

import numpy as np


class Colour(NamedTuple):
    rgb: tuple[int, int, int]
    name: str

    @property
    def hex(self) -> str:
        """``#rrggbb``, as matplotlib and rich take it."""
        return "#{:02x}{:02x}{:02x}".format(*self.rgb)


PIPELINE_COLOURS = {"rgbdslam": Colour((255, 140, 0), "orange"), "rtabmap": Colour((40, 150, 255), "blue")}
FALLBACK_COLOURS = (
    Colour((200, 80, 220), "purple"),
    Colour((60, 200, 120), "green"),
    Colour((230, 200, 40), "yellow"),
    Colour((0, 200, 210), "cyan"),
    Colour((240, 100, 150), "pink"),
    Colour((150, 110, 70), "brown"),
)

GROUNDTRUTH = Colour((170, 170, 170), "grey")
ACCEPTED = Colour((40, 220, 90), "green")
REJECTED = Colour((150, 40, 40), "dark red")
INLIER = Colour((40, 220, 90), "green")
OUTLIER = Colour((235, 50, 50), "red")
STATUS = {
    "initialising": Colour((150, 150, 150), "grey"),
    "ok": Colour((40, 220, 90), "green"),
    "relocalised": Colour((255, 200, 0), "yellow"),
    "lost": Colour((235, 50, 50), "red"),
}
LOST = STATUS["lost"]
CAUSES = {
    "sensor blocked": Colour((120, 120, 120), "grey"),
    "no depth": Colour((90, 60, 200), "indigo"),
    "fast motion": Colour((255, 140, 0), "orange"),
    "dynamic scene": Colour((200, 80, 220), "purple"),
    "too few features": Colour((235, 50, 50), "red"),
    "too few inliers": Colour((230, 200, 40), "yellow"),
    "unknown": Colour((170, 170, 170), "grey"),
}

# A pose coloured by its error: green at no error, through yellow, to red at the largest shown;
# a pose without a groundtruth pair (no error) dark grey.
ERROR_RAMP = (Colour((40, 220, 90), "green"), Colour((230, 200, 40), "yellow"), Colour((235, 50, 50), "red"))
NO_ERROR = Colour((110, 110, 110), "dark grey")


def run_colour(name: str, position: int = 0) -> Colour:
    """The colour of run ``name``, shown at ``position`` among the runs of one view."""
    return PIPELINE_COLOURS.get(name, FALLBACK_COLOURS[position % len(FALLBACK_COLOURS)])


def faded(colour: Colour, share: float = 0.55, towards: int = 90) -> tuple[int, int, int]:
    """``colour`` mixed with a dark grey: the same hue, in the background."""
    red, green, blue = (int((1 - share) * c + share * towards) for c in colour.rgb)
    return red, green, blue


def error_colours(errors: np.ndarray, top: float) -> np.ndarray:
    """``(N, 3)`` uint8: each error's place on :data:`ERROR_RAMP` from 0 to ``top`` (clamped), NaN dark grey."""
    errors = np.asarray(errors, dtype=np.float64)
    share = np.clip(np.nan_to_num(errors / top if top > 0 else errors * 0.0), 0.0, 1.0)
    stops = np.linspace(0.0, 1.0, len(ERROR_RAMP))
    rgb = np.stack(
        [np.interp(share, stops, [colour.rgb[channel] for colour in ERROR_RAMP]) for channel in range(3)], axis=1
    )
    rgb[~np.isfinite(errors)] = NO_ERROR.rgb
    return np.round(rgb).astype(np.uint8)
