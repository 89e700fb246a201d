"""Options that several commands share, spelt and parsed one way everywhere."""

import re

from ..errors import InputError

PIPELINE_HELP = ("Pipeline to run: rgbdslam, rtabmap, both or a plugin pipeline (`viewslam pipelines` lists them); "
                 "repeatable or comma-separated.")
MAX_FRAMES_HELP = "Process at most the first N frames of each sequence (after --stride where there is one)."
QUIET_HELP = "No progress display (results are still printed)."
SEED_MAX = 2**32 - 1  # numpy seeds are unsigned 32-bit words


def parse_resolution(text: str) -> tuple[int, int]:
    """``WIDTHxHEIGHT`` (e.g. ``640x480``) as a pair of integers, each at least 16 pixels."""
    match = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", text)
    if not match or not 16 <= min(int(match.group(1)), int(match.group(2))) <= max(
            int(match.group(1)), int(match.group(2))) <= 8192:
        raise InputError(f"--resolution {text!r}: expected WIDTHxHEIGHT, e.g. 640x480 or 320x240 "
                         f"(16 to 8192 pixels each)")
    return int(match.group(1)), int(match.group(2))
