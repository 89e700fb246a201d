"""Where an unexpected error's full traceback goes: a log file the one line on stderr names, so a
bug can be reported without the user ever seeing a traceback."""

import os
import sys
import tempfile
import time
import traceback
from pathlib import Path


def crash_log_note(error: BaseException) -> str:
    """Write the full traceback to a log file; ``"; full traceback in PATH"`` (or nothing if unwritable)."""
    text = "".join(traceback.format_exception(error))
    name = f"viewslam-crash-{time.strftime('%Y%m%d-%H%M%S')}-{os.getpid()}.log"
    for folder in (os.environ.get("VIEWSLAM_LOG_DIR"), tempfile.gettempdir()):
        if not folder:
            continue
        path = Path(folder) / name
        try:
            path.write_text(f"viewslam {' '.join(sys.argv[1:])}\n{text}", errors="backslashreplace")
        except OSError:
            continue
        return f"; full traceback in {path}"
    return ""
