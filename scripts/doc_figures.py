"""Writes the figures of README.md and docs/ that a command produces, so that none is typed by hand.

Each figure block of a document sits between two markers,

    <!-- figures: NAME -->
    ...
    <!-- /figures: NAME -->

and is made by running, as a user would, the commands that the document shows beside it.
`python scripts/doc_figures.py` re-runs every block and rewrites the documents;
`--check` writes nothing and exits 1 naming each block that no longer matches;
names select blocks (`python scripts/doc_figures.py --check demo`). The tests run the
same functions, so a figure that drifts from what its command prints fails the suite.
Commands run with this interpreter's viewslam, in a temporary folder, with the cache the
environment names (`VIEWSLAM_CACHE`).
"""

import argparse
import json
import re
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

REPO = Path(__file__).resolve().parents[1]
TUM_RPY = REPO.parent / "shared" / "data" / "tum" / "rgbd_dataset_freiburg1_rpy"


def viewslam(*args: str, cwd: Path | None = None) -> str:
    """Run one viewslam command; its stdout (a failure raises with its stderr)."""
    result = subprocess.run([sys.executable, "-m", "viewer_slam", *args], capture_output=True, text=True, cwd=cwd)
    if result.returncode != 0:
        raise RuntimeError(f"viewslam {' '.join(args)} exited {result.returncode}: {result.stderr.strip()}")
    return result.stdout


def demo(work: Path) -> str:
    """The built-in demo's figures, from the report `viewslam record` writes beside it."""
    viewslam("record", "--out", str(work / "demo.rrd"), "--quiet")
    report = json.loads((work / "demo.json").read_text())
    frames, runs = report["sequence"]["frames"], report["pipelines"]
    rgbdslam, rtabmap = runs["rgbdslam"], runs["rtabmap"]
    return (f"In this run: rgbdslam {rgbdslam['frames_with_pose']} of {frames} frames with a pose, "
            f"ATE {rgbdslam['ate']['rmse']:.3f} m, penalised {rgbdslam['penalized_ate']['rmse']:.3f} m;\n"
            f"rtabmap {rtabmap['frames_with_pose']} frames, {rtabmap['ate']['rmse']:.3f} m, "
            f"penalised {rtabmap['penalized_ate']['rmse']:.3f} m.")


def estimate(work: Path) -> str:
    """rgbdslam on the 87-frame excerpt, then its own trajectory file replayed beside it."""
    first, second = work / "rpy.rrd", work / "both.rrd"
    viewslam("record", str(TUM_RPY), "--pipeline", "rgbdslam", "--out", str(first), "--quiet")
    viewslam("record", str(TUM_RPY), "--pipeline", "rgbdslam", "--out", str(second), "--quiet",
             "--estimate", f"mine={first.with_suffix('.rgbdslam.txt')}")
    report = json.loads(second.with_suffix(".json").read_text())
    pipeline, mine = report["pipelines"]["rgbdslam"], report["pipelines"]["mine"]
    return (f"On the shared fr1/rpy excerpt ({report['sequence']['frames']} frames), rgbdslam's trajectory "
            f"file replayed as `mine`\nbeside rgbdslam scores ATE RMSE {mine['ate']['rmse']:.7f} m against "
            f"rgbdslam's {pipeline['ate']['rmse']:.7f} m\n(the file keeps 6 decimals), RPE "
            f"{mine['rpe']['trans']['rmse']:.4f} m against {pipeline['rpe']['trans']['rmse']:.4f} m, coverage "
            f"{mine['coverage']['ratio']:.0%} against {pipeline['coverage']['ratio']:.0%}.")


def diff(work: Path) -> str:
    """rtabmap without and with odometry resets on a short 360_kidnap, compared by `viewslam diff`."""
    viewslam("synth", "360_kidnap", "--out", "kidnap", "--frames", "120", "--resolution", "320x240", cwd=work)
    for name, countdown in (("reset0", 0), ("reset5", 5)):
        viewslam("record", "kidnap", "--pipeline", "rtabmap", "--param", "Rtabmap/DetectionRate=5",
                 "--param", f"Odom/ResetCountdown={countdown}", "--out", f"runs/{name}.rrd", "--quiet", cwd=work)
    return diff_table(viewslam("diff", "runs/reset0.json", "runs/reset5.json", cwd=work))


def diff_table(printed: str) -> str:
    """What `viewslam diff` printed, less the timing row (timings are no reproducible figure)."""
    lines = [line.rstrip() for line in printed.strip("\n").splitlines() if not line.lstrip().startswith("frames/s")]
    return "\n".join(["```", *lines, "```"])


@dataclass(frozen=True)
class Figures:
    document: str
    make: Callable[[Path], str]


FIGURES = {
    "demo": Figures("README.md", demo),
    "estimate": Figures("README.md", estimate),
    "diff": Figures("docs/diagnosis.md", diff),
}


def _block(name: str) -> re.Pattern[str]:
    return re.compile(rf"(<!-- figures: {name} -->\n)(.*?)(<!-- /figures: {name} -->)", re.DOTALL)


def written(text: str, name: str) -> str:
    """The block ``name`` as the document holds it."""
    found = _block(name).search(text)
    if found is None:
        raise ValueError(f"no figure block {name!r}")
    return found.group(2).removesuffix("\n")


def with_block(text: str, name: str, content: str) -> str:
    """The document with the block ``name`` replaced by ``content``."""
    written(text, name)
    return _block(name).sub(lambda found: found.group(1) + content + "\n" + found.group(3), text)


def made(name: str) -> str:
    """The block ``name`` as its commands print it now."""
    with tempfile.TemporaryDirectory(prefix=f"viewslam-{name}-") as work:
        return FIGURES[name].make(Path(work))


def stale(documents: dict[str, str], figures: dict[str, str]) -> list[str]:
    """The names of the blocks whose text in ``documents`` (path to text) is not ``figures``'."""
    return [name for name, content in figures.items() if written(documents[FIGURES[name].document], name) != content]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("names", nargs="*", metavar="NAME", help=f"blocks to make: {', '.join(FIGURES)} (all by default)")
    parser.add_argument("--check", action="store_true", help="write nothing; exit 1 if a block differs")
    options = parser.parse_args()
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
