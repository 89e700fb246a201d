"""Options that several commands share, spelt and parsed one way everywhere."""

import math
import re

import typer

from ..errors import InputError
from ..evaluation.coverage import Span

MAX_FRAMES_HELP = "Process at most the first N frames of each sequence (after --stride where there is one)."
QUIET_HELP = "No progress display (results are still printed)."
SPAN_OPTION_RULE = "--span"


def parse_resolution(text: str) -> tuple[int, int]:
    """``WIDTHxHEIGHT`` (e.g. ``640x480``) as a pair of integers, each at least 16 pixels."""
    match = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", text)
    if (
        not match
        or not 16
        <= min(int(match.group(1)), int(match.group(2)))
        <= max(int(match.group(1)), int(match.group(2)))
        <= 8192
    ):
        raise InputError(
            f"--resolution {text!r}: expected WIDTHxHEIGHT, e.g. 640x480 or 320x240 (16 to 8192 pixels each)"
        )
    return int(match.group(1)), int(match.group(2))


def finite(value: float) -> float:
    """A typer callback: ``value`` unless it is NaN or infinite."""
    if not math.isfinite(value):
        raise typer.BadParameter(f"must be a finite number, got {value}")
    return value


def positive(value: float) -> float:
    """A typer callback: ``value`` if it is finite and positive."""
    if not (math.isfinite(value) and value > 0):
        raise typer.BadParameter(f"must be a finite positive number, got {value}")
    return value


def parse_span(text: str | None) -> Span | None:
    """``START,END`` in groundtruth seconds, START before END (``--span``)."""
    if text is None:
        return None
    try:
        start, end = (float(field) for field in text.split(","))
    except ValueError:
        raise typer.BadParameter(f"expected START,END in seconds, got {text!r}") from None
    if not (math.isfinite(start) and math.isfinite(end) and start < end):
        raise typer.BadParameter(f"expected two finite stamps with START < END, got {text!r}")
    return Span(start, end, SPAN_OPTION_RULE)
