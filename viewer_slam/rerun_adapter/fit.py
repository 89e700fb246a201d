"""What fits in the layout's views at the smallest window it is made for, 1280x800.

Measured on the Rerun viewer's screenshot at that size (docs/images/viewer_demo_1280x800.png):
its interface font averages 6.2 px a character in view titles and log rows, and a view's tab
keeps about 130 px for its icon and buttons (help, visibility, maximise, the overflow
arrow). Texts are sized at 6.5 px a character, for a margin. The text log view shows one
row per entry, the first line of a multi-line text only, cut at the column's edge: a
message longer than a row becomes several entries, the later ones indented.
"""

import textwrap

SMALLEST_WIDTH_PX = 1280
CHAR_PX = 6.5
TAB_CHROME_PX = 130
LOG_COLUMNS_PX = 140  # the log view's frame and level columns, and its scroll bar
# The main layout's two columns: the 3D view over the log | the images, plots and states.
LEFT_SHARE, RIGHT_SHARE = 1.35, 1.0
CONTINUATION = "    "  # the indent of a message's later rows


def column_px(share: float, side_by_side: int = 1) -> float:
    """Width at 1280 px of one of ``side_by_side`` views sharing a column of ``share``."""
    return SMALLEST_WIDTH_PX * share / (LEFT_SHARE + RIGHT_SHARE) / side_by_side


def title_chars(width_px: float) -> int:
    """The longest title a view ``width_px`` wide shows whole."""
    return int((width_px - TAB_CHROME_PX) // CHAR_PX)


LOG_LINE_CHARS = int((column_px(LEFT_SHARE) - LOG_COLUMNS_PX) // CHAR_PX)


def log_rows(text: str) -> list[str]:
    """``text`` as rows of at most :data:`LOG_LINE_CHARS`, broken between words."""
    return textwrap.wrap(text, LOG_LINE_CHARS, subsequent_indent=CONTINUATION, break_on_hyphens=False) or [""]
