"""What `viewslam record` prints: a progress bar per pipeline while it runs, a summary after."""

import time

from rich import box
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, TextColumn, TimeElapsedColumn
from rich.table import Table
from rich.text import Text

from .. import palette
from ..pipelines.events import Event, FrameTracked
from ..pipelines.run import Sink
from ..progress import StderrProgress
from ..terminal import StdoutConsole, print_table

_STATE_STYLES = {
    status: f"bold {colour.hex}" if status == "lost" else colour.hex for status, colour in palette.STATUS.items()
}


class RecordProgress:
    """A rich progress bar per pipeline with frames/s and the current tracking state.

    Goes to stderr so that stdout stays for the summary; ``quiet`` disables it.
    """

    def __init__(self, total_frames: int, quiet: bool = False):
        self.total_frames = total_frames
        self._progress = StderrProgress(
            TextColumn("[bold {task.fields[colour]}]{task.description:<9}"),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn("{task.fields[fps]:5.1f} frames/s"),
            TextColumn("{task.fields[state]}"),
            TimeElapsedColumn(),
            enabled=not quiet,
        )

    def __enter__(self) -> "RecordProgress":
        self._progress.__enter__()
        return self

    def __exit__(self, *exc_info) -> None:
        self._progress.__exit__(*exc_info)

    def sink(self, pipeline: str) -> Sink:
        """A sink that advances ``pipeline``'s bar on every tracked frame."""
        colour = palette.run_colour(pipeline, len(self._progress.tasks)).hex
        task = self._progress.add_task(pipeline, total=self.total_frames, fps=0.0, state="", colour=colour)
        start = time.perf_counter()
        frames = 0

        def advance(event: Event) -> None:
            nonlocal frames
            if not isinstance(event, FrameTracked):
                return
            frames += 1
            status = event.status.value
            self._progress.update(
                task,
                advance=1,
                fps=frames / max(time.perf_counter() - start, 1e-9),
                state=f"[{_STATE_STYLES.get(status, '')}]{status}",
            )

        return advance


def _rmse(block: dict | None, decimals: int = 3) -> str:
    return "—" if not block else f"{block['rmse']:.{decimals}f}"


def _pipeline_cells(block: dict) -> tuple[str, str]:
    """Loops and frames/s: what a pipeline measures; an estimate replayed from a file has neither."""
    if block.get("source") == "estimate":
        return "—", "—"
    return f"{block['loop_closures']['accepted']}/{block['loop_closures']['rejected']}", f"{block['timing']['fps']:.1f}"


def print_summary(report: dict, written: list, console: Console | None = None) -> None:
    """One row per pipeline with the headline scores, then the files written."""
    console = console or StdoutConsole()
    alignments = sorted({block["alignment"] for block in report["pipelines"].values() if block.get("alignment")})
    caption = (
        f"RMSE in m, RPE rot in deg; ATE, penal. ATE: {'/'.join(alignments) or 'rigid'} alignment of the "
        "whole run (each tracked segment aligned on its own: ate_segments in the report); RPE over 1 s, "
        "needs no alignment; loops ok/rejected"
    )
    table = Table(
        title=f"{report['sequence']['name']}" + ("  (interrupted)" if report["interrupted"] else ""),
        box=box.SIMPLE_HEAD,
        pad_edge=False,
        collapse_padding=True,
        caption=caption,
    )
    for column in ("pipeline", "poses", "coverage", "ATE", "penal.\nATE", "RPE\ntrans", "RPE\nrot", "loops", "fps"):
        table.add_column(column, justify="left" if column == "pipeline" else "right", no_wrap=True)
    for position, (name, block) in enumerate(report["pipelines"].items()):
        rpe = block["rpe"] or {}
        coverage = block["coverage"]
        table.add_row(
            Text(name, style=palette.run_colour(name, position).hex),
            str(block["frames_with_pose"]),
            "—" if coverage is None else f"{coverage['ratio']:.0%}",
            _rmse(block["ate"]),
            _rmse(block["penalized_ate"]),
            _rmse(rpe.get("trans")),
            _rmse(rpe.get("rot"), 2),
            *_pipeline_cells(block),
        )
    print_table(table, console)
    for block in report["pipelines"].values():
        for loss in block.get("tracking_lost", []):
            if "text" in loss:
                console.print(loss["text"], markup=False, highlight=False)
    for path in written:
        console.print(f"wrote {path}")
