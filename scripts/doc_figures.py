"""Writes the figures of README.md and docs/ that a command produces, so that none is typed by hand.

Each figure block of a document sits between two markers,

    <!-- figures: NAME -->
    ...
    <!-- /figures: NAME -->

and is made by running, as a user would, the commands that the document shows beside it.
`python -m scripts.doc_figures` re-runs every block and rewrites the documents;
`--check` writes nothing and exits 1 naming each block that no longer matches;
names select blocks (`python -m scripts.doc_figures --check demo`). The tests run the
same functions, so a figure that drifts from what its command prints fails the suite.
Commands run with this interpreter's viewslam, in temporary folders, with the cache the
environment names (`VIEWSLAM_CACHE`); the demo is recorded once for the blocks that read it.
"""

import argparse
import functools
import json
import re
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import viewer_slam.code_paths  # noqa: F401  (before NumPy loads: holds it to one code path)

import numpy as np

from benchmarks.figures import REPO, SHARED_DATA, TUM, scratch, with_block, written

TUM_RPY = TUM / "rgbd_dataset_freiburg1_rpy"


def viewslam(*args: str, cwd: Path | None = None) -> str:
    """Run one viewslam command; its stdout (a failure raises with its stderr)."""
    result = subprocess.run(
        [sys.executable, "-m", "viewer_slam", *args], capture_output=True, text=True, cwd=cwd, check=False
    )
    if result.returncode != 0:
        raise RuntimeError(f"viewslam {' '.join(args)} exited {result.returncode}: {result.stderr.strip()}")
    return result.stdout


@functools.cache
def demo_run() -> Path:
    """The built-in demo recorded once (`viewslam record` with no sequence): its folder."""
    work = scratch()
    viewslam("record", "--out", str(work / "demo.rrd"), "--quiet")
    return work


def demo() -> str:
    """The built-in demo's figures, from the report `viewslam record` writes beside it."""
    report = json.loads((demo_run() / "demo.json").read_text())
    frames, runs = report["sequence"]["frames"], report["pipelines"]
    rgbdslam, rtabmap = runs["rgbdslam"], runs["rtabmap"]
    return (
        f"In this run: rgbdslam {rgbdslam['frames_with_pose']} of {frames} frames with a pose, "
        f"ATE {rgbdslam['ate']['rmse']:.3f} m, penalised {rgbdslam['penalized_ate']['rmse']:.3f} m;\n"
        f"rtabmap {rtabmap['frames_with_pose']} frames, {rtabmap['ate']['rmse']:.3f} m, "
        f"penalised {rtabmap['penalized_ate']['rmse']:.3f} m."
    )


def segments() -> str:
    """On the demo, each pipeline's ATE under one alignment and with each tracked segment
    aligned on its own, before its first loss and over the run."""
    from viewer_slam.dataset.sources import open_source
    from viewer_slam.evaluation import evaluate
    from viewer_slam.geometry.trajectory import read_tum

    report = json.loads((demo_run() / "demo.json").read_text())
    sequence = open_source(Path(report["sequence"]["path"]))
    lines = []
    if sequence.groundtruth is None:
        raise RuntimeError(f"{sequence.path}: the demo has no groundtruth")
    for name in report["pipelines"]:
        trajectory = read_tum(demo_run() / f"demo.{name}.txt")
        evaluation = evaluate(sequence.groundtruth, trajectory, frame_period=sequence.frame_period)
        if evaluation.ate is None or evaluation.segment_ate is None:
            raise RuntimeError(f"demo.{name}.txt: no pose paired with the groundtruth")
        tracked = np.isin(np.round(sequence.timestamps, 6), np.round(trajectory.timestamps, 6))
        lost = _runs(np.flatnonzero(~tracked))
        first_loss = sequence.timestamps[lost[0][0]] if lost else np.inf
        before = [series.errors[series.timestamps < first_loss] for series in (evaluation.ate, evaluation.segment_ate)]
        lines.append(
            f"{name} is lost over frames {_frames(lost)}; before its first loss the globally aligned ATE averages "
            f"{before[0].mean():.3f} m (at most {before[0].max():.3f} m) and the segment-aligned one "
            f"{before[1].mean():.3f} m (at most {before[1].max():.3f} m); over the run the RMSE is "
            f"{evaluation.ate.stats()['rmse']:.3f} m globally and {evaluation.segment_ate.stats()['rmse']:.3f} m "
            f"per segment."
        )
    return "\n".join(lines)


def _runs(indices: np.ndarray) -> list[tuple[int, int]]:
    """Consecutive indices as (first, last) runs."""
    breaks = np.flatnonzero(np.diff(indices) > 1)
    return [(int(run[0]), int(run[-1])) for run in np.split(indices, breaks + 1) if len(run)]


def _frames(runs: list[tuple[int, int]]) -> str:
    spans = [f"{first}–{last}" for first, last in runs]
    return " and ".join([", ".join(spans[:-1]), spans[-1]] if len(spans) > 1 else spans) or "none"


def scenario() -> str:
    """The scenario.json that `viewslam synth` writes beside a short 360_kidnap."""
    work = scratch()
    viewslam("synth", "360_kidnap", "--out", "kidnap", "--frames", "30", "--resolution", "160x120", cwd=work)
    written = json.loads((work / "kidnap" / "scenario.json").read_text())
    keys = ",\n".join(f" {json.dumps(key)}: {json.dumps(value)}" for key, value in written.items())
    return "```json\n{\n" + keys + "\n}\n```"


def cache_need() -> str:
    """What the default benchmark's rendered scenarios take in the cache: each scenario's PNGs
    as the generator writes them, measured on frames spread over its run, times its length."""
    from viewer_slam.dataset.synth import STUDY_SCENARIOS, default_frames, preview_frames
    from viewer_slam.dataset.synth.writer import encode_frame

    fractions = np.linspace(0, 1, 5)
    colour = depth = frames = total = 0
    for name in STUDY_SCENARIOS:
        sizes = np.array(
            [
                [len(png) for png in encode_frame(rgb, metres, 5000.0)]
                for _, rgb, metres in preview_frames(name, fractions)
            ]
        )
        colour, depth = colour + sizes[:, 0].sum(), depth + sizes[:, 1].sum()
        frames += default_frames(name)
        total += default_frames(name) * sizes.sum(axis=1).mean()
    sampled = len(STUDY_SCENARIOS) * len(fractions)
    return (
        f"The default `viewslam benchmark` renders the seven scenarios at 640x480 and their own lengths, "
        f"{frames:,} frames,\ninto about {total / 1e9:.1f} GB of cache: "
        f"{total / frames / 1e6:.2f} MB a frame (colour {colour / sampled / 1e3:.0f} kB, stored "
        f"uncompressed; depth {depth / sampled / 1e3:.0f} kB\non average), measured on "
        f"{len(fractions)} frames spread over each run."
    )


def estimate() -> str:
    """rgbdslam on the 87-frame excerpt, then its own trajectory file replayed beside it."""
    work = scratch()
    first, second = work / "rpy.rrd", work / "both.rrd"
    viewslam("record", str(TUM_RPY), "--pipeline", "rgbdslam", "--out", str(first), "--quiet")
    viewslam(
        "record",
        str(TUM_RPY),
        "--pipeline",
        "rgbdslam",
        "--out",
        str(second),
        "--quiet",
        "--estimate",
        f"mine={first.with_suffix('.rgbdslam.txt')}",
    )
    report = json.loads(second.with_suffix(".json").read_text())
    pipeline, mine = report["pipelines"]["rgbdslam"], report["pipelines"]["mine"]
    return (
        f"On the shared fr1/rpy excerpt ({report['sequence']['frames']} frames), rgbdslam's trajectory "
        f"file replayed as `mine`\nbeside rgbdslam scores ATE RMSE {mine['ate']['rmse']:.7f} m against "
        f"rgbdslam's {pipeline['ate']['rmse']:.7f} m\n(the file keeps 6 decimals), RPE "
        f"{mine['rpe']['trans']['rmse']:.4f} m against {pipeline['rpe']['trans']['rmse']:.4f} m, coverage "
        f"{mine['coverage']['ratio']:.0%} against {pipeline['coverage']['ratio']:.0%}."
    )


def diff() -> str:
    """rtabmap without and with odometry resets on a short 360_kidnap, compared by `viewslam diff`."""
    work = scratch()
    viewslam("synth", "360_kidnap", "--out", "kidnap", "--frames", "120", "--resolution", "320x240", cwd=work)
    for name, countdown in (("reset0", 0), ("reset5", 5)):
        viewslam(
            "record",
            "kidnap",
            "--pipeline",
            "rtabmap",
            "--param",
            "Rtabmap/DetectionRate=5",
            "--param",
            f"Odom/ResetCountdown={countdown}",
            "--out",
            f"runs/{name}.rrd",
            "--quiet",
            cwd=work,
        )
    return diff_table(viewslam("diff", "runs/reset0.json", "runs/reset5.json", cwd=work))


def diff_table(printed: str) -> str:
    """What `viewslam diff` printed, less the timing row (timings are no reproducible figure),
    the score table's columns aligned again without it (its numbers set their widths)."""
    lines = [line.rstrip() for line in printed.strip("\n").splitlines() if not line.lstrip().startswith("frames/s")]
    table = [k for k, line in enumerate(lines) if line.startswith(" ") and line.strip()]
    rows = {k: re.split(r"\s{2,}", lines[k].strip()) for k in table if not set(lines[k].strip()) <= {"─"}}
    if rows:
        columns = max(len(cells) for cells in rows.values())
        widths = [max(len(cells[c]) for cells in rows.values() if c < len(cells)) for c in range(columns)]
        for k in table:
            cells = rows.get(k)
            lines[k] = (
                " " + "─" * (sum(widths) + 3 * (columns - 1))
                if cells is None
                else " "
                + cells[0].ljust(widths[0])
                + "".join("   " + cell.rjust(width) for cell, width in zip(cells[1:], widths[1:]))
            )
    return "\n".join(["```", *lines, "```"])


STUDY_COPY = SHARED_DATA / "study_kasar2018"
STUDY_SEQUENCES = (
    "fr2/360_kidnap",
    "fr3/long_office_household",
    "fr3/nostructure_notexture_near_withloop",
    "fr3/sitting_static",
)


@functools.cache
def study_report() -> str:
    """`viewslam study` on the four sequences whose published runs are at hand, fetched from
    their copy beside the repository: its report.md, with the copy's address as the
    documents show it (relative, so that the figures do not hang on where the copy lies)."""
    work = scratch()
    mirror = STUDY_COPY.as_uri()
    viewslam("study", *STUDY_SEQUENCES, "--out", "study", "--mirror", mirror, "--quiet", cwd=work)
    return (work / "study" / "report.md").read_text().replace(mirror, "../shared/data/study_kasar2018")


def study_table() -> str:
    """The study's table, published beside reproduced, for the README."""
    report = study_report()
    return report[report.index("| sequence") : report.index("\n## Findings")].rstrip()


def study() -> str:
    """The whole report of `viewslam study`, for docs/study.md."""
    return study_report().split("\n", 1)[1].strip()


@dataclass(frozen=True)
class Figures:
    document: str
    make: Callable[[], str]


FIGURES = {
    "demo": Figures("README.md", demo),
    "estimate": Figures("README.md", estimate),
    "cache": Figures("README.md", cache_need),
    "study-table": Figures("README.md", study_table),
    "study": Figures("docs/study.md", study),
    "segments": Figures("docs/metrics.md", segments),
    "diff": Figures("docs/diagnosis.md", diff),
    "scenario": Figures("docs/scenarios.md", scenario),
}


def made(name: str) -> str:
    """The block ``name`` as its commands print it now."""
    return FIGURES[name].make()


def stale(documents: dict[str, str], figures: dict[str, str]) -> list[str]:
    """The names of the blocks whose text in ``documents`` (path to text) is not ``figures``'."""
    return [name for name, content in figures.items() if written(documents[FIGURES[name].document], name) != content]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m scripts.doc_figures", description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "names", nargs="*", metavar="NAME", help=f"blocks to make: {', '.join(FIGURES)} (all by default)"
    )
    parser.add_argument("--check", action="store_true", help="write nothing; exit 1 if a block differs")
    options = parser.parse_args(argv)
    unknown = set(options.names) - FIGURES.keys()
    if unknown:
        parser.error(f"no figure block {', '.join(sorted(unknown))}")
    figures = {name: made(name) for name in options.names or FIGURES}
    documents = {FIGURES[name].document: (REPO / FIGURES[name].document).read_text() for name in figures}
    for name in stale(documents, figures):
        document = FIGURES[name].document
        if options.check:
            print(f"{document}: the figures '{name}' differ from what their commands print")
            continue
        documents[document] = with_block(documents[document], name, figures[name])
        (REPO / document).write_text(documents[document])
        print(f"rewrote the figures '{name}' in {document}")
    return 1 if options.check and stale(documents, figures) else 0


if __name__ == "__main__":
    sys.exit(main())
