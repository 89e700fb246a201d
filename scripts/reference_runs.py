"""The reference runs, whose bytes every x86-64 machine with AVX2 must reproduce.

    python -m scripts.reference_runs                  # record them; rewrite tests/reference_runs/
    python -m scripts.reference_runs --check          # record them; exit 1 naming each difference
    python -m scripts.reference_runs --check --emulate all   # once per CPU setting, each alone

The runs: `viewslam record` of the built-in demo (rendered anew, into a cache of the run's own)
and of the 200-frame fr1/rpy excerpt, both pipelines, seed 0. `tests/reference_runs/` keeps
their trajectory files and `SHA256SUMS`, the digest of each file, of the demo's rendered
frames and of each report's figures (every figure but the times and the paths). A check
records the runs again and names what differs, with the first frame where a trajectory parts
from the reference.

`--emulate` records them under settings that hold one library to the code path another
processor would take (NumPy's SIMD loops, OpenBLAS's kernels, numba's target; OpenCV's
dispatch is held off AVX-512 by viewslam itself), each in a fresh process: `all` runs every setting this CPU can run, one at a time;
a name runs one. The test suite checks the defaults and two emulated machines
(`tests/project/test_same_bytes.py`).
"""

import argparse
import hashlib
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from viewer_slam.code_paths import cpu_flags

from benchmarks.figures import REPO, TUM

REFERENCE = REPO / "tests" / "reference_runs"
TUM_RPY_200 = TUM / "rgbd_dataset_freiburg1_rpy_200"
RUNS = ("demo", "rpy200")
PIPELINES = ("rgbdslam", "rtabmap")
AVX512 = ("avx512f", "avx512cd", "avx512bw", "avx512dq", "avx512vl")

#: One library on another code path each: (CPU flags the setting needs, its environment).
SETTINGS: dict[str, tuple[tuple[str, ...], dict[str, str]]] = {
    "NumPy without AVX2": ((), {"NPY_DISABLE_CPU_FEATURES": "X86_V3 X86_V4 AVX512_ICL AVX512_SPR"}),
    "OpenBLAS Haswell": (("avx2",), {"OPENBLAS_CORETYPE": "Haswell"}),
    "OpenBLAS Zen": (("avx2",), {"OPENBLAS_CORETYPE": "Zen"}),
    "OpenBLAS SkylakeX": (AVX512, {"OPENBLAS_CORETYPE": "SkylakeX"}),
    "OpenBLAS Cooperlake": ((*AVX512, "avx512_bf16"), {"OPENBLAS_CORETYPE": "Cooperlake"}),
    "numba generic x86-64": ((), {"NUMBA_CPU_NAME": "generic"}),
    "numba haswell": (("avx2",), {"NUMBA_CPU_NAME": "haswell"}),
    "numba skylake-avx512": (AVX512, {"NUMBA_CPU_NAME": "skylake-avx512"}),
}

#: Whole machines, every library at once, as the test suite emulates them.
MACHINES: dict[str, tuple[tuple[str, ...], dict[str, str]]] = {
    "AVX2 without AVX-512": (("avx2",), {"OPENBLAS_CORETYPE": "Zen", "NUMBA_CPU_NAME": "generic"}),
    "Intel with AVX-512": (AVX512, {"OPENBLAS_CORETYPE": "SkylakeX", "NUMBA_CPU_NAME": "skylake-avx512"}),
}


def runnable(settings: dict[str, tuple[tuple[str, ...], dict[str, str]]]) -> dict[str, dict[str, str]]:
    """The settings whose code this CPU can run."""
    flags = cpu_flags()
    return {name: environment for name, (needs, environment) in settings.items() if flags.issuperset(needs)}


def record_runs(out: Path, environment: dict[str, str] | None = None) -> Path:
    """Both runs recorded into ``out`` under ``environment`` (added to this process's)."""
    out.mkdir(parents=True, exist_ok=True)
    env = {**os.environ, **(environment or {}), "VIEWSLAM_CACHE": str(out / "cache")}
    for name, source in (("demo", []), ("rpy200", [str(TUM_RPY_200)])):
        result = subprocess.run(
            [
                sys.executable,
                "-m",
                "viewer_slam",
                "record",
                *source,
                "--pipeline",
                "both",
                "--seed",
                "0",
                "--out",
                str(out / f"{name}.rrd"),
                "--quiet",
            ],
            env=env,
            capture_output=True,
            text=True,
            check=False,
        )
        if result.returncode != 0:
            raise RuntimeError(f"viewslam record {name} exited {result.returncode}: {result.stderr.strip()}")
    return out


def _sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def figures(report: dict) -> dict:
    """A report's figures: everything but the times, the paths and the versions."""
    sequence = {key: value for key, value in report["sequence"].items() if key != "path"}
    runs = {
        name: {key: value for key, value in run.items() if key != "timing"} for name, run in report["pipelines"].items()
    }
    return {"sequence": sequence, "pipelines": runs}


def digests(folder: Path) -> dict[str, str]:
    """The digests of a folder of recorded runs: trajectory files, the demo's frames, figures."""
    found = {
        f"{run}.{pipeline}.txt": _sha256((folder / f"{run}.{pipeline}.txt").read_bytes())
        for run in RUNS
        for pipeline in PIPELINES
    }
    frames = hashlib.sha256()
    for path in sorted((folder / "cache").rglob("*.png")):
        frames.update(
            path.relative_to(folder / "cache").as_posix().encode() + bytes.fromhex(_sha256(path.read_bytes()))
        )
    found["demo frames"] = frames.hexdigest()
    for run in RUNS:
        report = json.loads((folder / f"{run}.json").read_text())
        found[f"{run} figures"] = _sha256(json.dumps(figures(report), sort_keys=True).encode())
    return found


def read_sums(path: Path) -> dict[str, str]:
    return {name: digest for digest, name in (line.split("  ", 1) for line in path.read_text().splitlines())}


def first_difference(reference: str, other: str) -> str:
    """Where two trajectory files first part: the pose's line and stamp."""
    for number, (a, b) in enumerate(zip(reference.splitlines(), other.splitlines()), start=1):
        if a != b:
            return f"first differs at line {number}, the pose at {a.split()[0]} (this run: {b.split()[0]})"
    return f"{len(reference.splitlines())} poses in the reference, {len(other.splitlines())} in this run"


def differences(folder: Path, reference: Path = REFERENCE) -> list[str]:
    """What the runs in ``folder`` compute differently from the committed reference."""
    return compare(digests(folder), folder, reference)


def compare(found: dict[str, str], folder: Path, reference: Path = REFERENCE) -> list[str]:
    """Each digest of ``found`` that is not the reference's, with the first differing frame of
    a trajectory file (``folder`` holds the files)."""
    expected = read_sums(reference / "SHA256SUMS")
    lines = []
    for name, digest in expected.items():
        if found.get(name) == digest:
            continue
        where = ""
        if name.endswith(".txt"):
            where = ": " + first_difference((reference / name).read_text(), (folder / name).read_text())
        lines.append(f"{name} differs{where}")
    return lines


def write_reference(folder: Path, reference: Path = REFERENCE) -> None:
    reference.mkdir(parents=True, exist_ok=True)
    for run in RUNS:
        for pipeline in PIPELINES:
            shutil.copyfile(folder / f"{run}.{pipeline}.txt", reference / f"{run}.{pipeline}.txt")
    (reference / "SHA256SUMS").write_text("".join(f"{digest}  {name}\n" for name, digest in digests(folder).items()))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m scripts.reference_runs", description=__doc__.split("\n\n")[0])
    parser.add_argument("--check", action="store_true", help="write nothing; exit 1 if a run differs")
    parser.add_argument(
        "--emulate",
        default=None,
        metavar="SETTING",
        help=f"'all', or one of: {', '.join(SETTINGS)}; {', '.join(MACHINES)}",
    )
    options = parser.parse_args(argv)
    settings: dict[str, dict[str, str]] = {"this machine's defaults": {}}
    if options.emulate == "all":
        settings = runnable(SETTINGS)
    elif options.emulate:
        known = {**runnable(SETTINGS), **runnable(MACHINES)}
        if options.emulate not in known:
            parser.error(f"--emulate {options.emulate!r}: not a setting this CPU can run")
        settings = {options.emulate: known[options.emulate]}
    if not options.check and options.emulate:
        parser.error("--emulate needs --check: the reference is written at the defaults")
    work = Path(tempfile.mkdtemp(prefix="viewslam-reference-runs-"))
    failed = False
    try:
        for number, (name, environment) in enumerate(settings.items()):
            folder = record_runs(work / str(number), environment)
            if not options.check:
                write_reference(folder)
                print(f"wrote {REFERENCE.relative_to(REPO)}")
                continue
            found = differences(folder)
            failed |= bool(found)
            print(f"| {name} | {'; '.join(found) or 'identical'} |", flush=True)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
