"""Small copies of a keyframe's images, for the recording's keyframe views."""

import cv2
import numpy as np

THUMBNAIL_WIDTH = 160


def thumbnail(image: np.ndarray, nearest: bool = False) -> np.ndarray:
    """``image`` shrunk to THUMBNAIL_WIDTH pixels across (a copy if already that small).

    Colour is averaged (area interpolation); depth takes ``nearest`` so that no invented
    depth appears between a foreground and a background pixel.
    """
    height, width = image.shape[:2]
    if width <= THUMBNAIL_WIDTH:
        return image.copy()
    size = (THUMBNAIL_WIDTH, round(height * THUMBNAIL_WIDTH / width))
    return cv2.resize(image, size, interpolation=cv2.INTER_NEAREST if nearest else cv2.INTER_AREA)
