"""Compact encodings of the images a recording keeps: JPEG colour, 16-bit PNG depth."""

import cv2
import numpy as np
import rerun as rr

JPEG_QUALITY = 75


def jpeg_bytes(rgb: np.ndarray, quality: int = JPEG_QUALITY) -> bytes:
    ok, data = cv2.imencode(".jpg", cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, quality])
    if not ok:
        raise ValueError("JPEG encoding failed")
    return data.tobytes()


def jpeg(rgb: np.ndarray, quality: int = JPEG_QUALITY) -> rr.EncodedImage:
    return rr.EncodedImage(contents=jpeg_bytes(rgb, quality), media_type="image/jpeg")


def depth_png(depth: np.ndarray) -> bytes:
    """Depth in metres as a 16-bit PNG in millimetres, 0 kept as no measurement (for display)."""
    millimetres = np.round(np.clip(depth, 0.0, 65.535) * 1000.0).astype(np.uint16)
    ok, data = cv2.imencode(".png", millimetres)
    if not ok:
        raise ValueError("PNG encoding failed")
    return data.tobytes()
