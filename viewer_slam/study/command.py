"""``viewslam study`` as a library function: the seed study's runs fetched, replayed and scored
as the study scored them, with the coverage-aware scores beside, and reported."""

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from ..errors import InputError
from ..geometry.trajectory_formats import TrajectoryFormat
from .fetch import check_mirror, fetch, study_cache
from .manifest import (
    CHARTS,
    SEQUENCES,
    SYSTEMS,
    StudySequence,
    groundtruth_path,
    known_sequence,
    poses_path,
    sequence_files,
)
from .replay import Run


@dataclass(frozen=True)
class StudyResult:
    """Every sequence × system run with its published and reproduced figures, every discrepancy
    between them (each a dict with its ``text``), and the files written."""

    runs: tuple[Run, ...]
    discrepancies: tuple[dict, ...]
    written: tuple[Path, ...]


def study(
    sequences: Sequence[str] = (),
    *,
    out: Path = Path("study-results"),
    mirror: str | None = None,
    record: bool = False,
    quiet: bool = True,
    command: str = "viewslam study",
) -> StudyResult:
    """Fetch the study's runs of ``sequences`` (names as :func:`study_sequences` knows them; none:
    all seven) from ``mirror`` (default: ``$VIEWSLAM_STUDY_MIRROR``, else the author's repository at
    the pinned commit) into the cache, SHA-256 checked; score them as the study did and with
    coverage; write ``results.json``, ``report.md`` (stamped with ``command``) and the charts into
    ``out``. With ``record``, also ``out/<sequence>.rrd``: both runs against the groundtruth, as
    :func:`~viewer_slam.record.command.record` records trajectory files alone. ``quiet`` hides the
    download progress.
    """
    selected = study_sequences(sequences)
    base = check_mirror(mirror)
    out.mkdir(parents=True, exist_ok=True) if not out.exists() else None
    if not out.is_dir():
        raise InputError.at(out, "is not a folder; --out takes a folder")
    cache = study_cache()
    files = {}
    for path in list(CHARTS) + [path for sequence in selected for path in sequence_files(sequence)]:
        files[path] = fetch(path, base, cache, progress=not quiet)

    from .replay import replay  # the scoring loads only once the files are here
    from .study_outputs import write_all

    runs, found = replay(files, selected)
    written = write_all(out, runs, found, base, command)
    if record:
        from ..record.files import record_trajectory_files  # Rerun loads only for recordings

        for sequence in selected:
            recorded = record_trajectory_files(
                files[groundtruth_path(sequence)][0],
                [(system.name, files[poses_path(sequence, system)][0]) for system in SYSTEMS],
                out / f"{sequence.name}.rrd",
                format=TrajectoryFormat.TUM,
                name=sequence.name,
            )
            written.extend(recorded.written)
    return StudyResult(tuple(runs), tuple(found), tuple(written))


def study_sequences(names: Sequence[str] = ()) -> list[StudySequence]:
    """The study's sequences ``names`` give (a TUM name, fr2/360_kidnap or the author's folder; none:
    all seven); an :class:`~viewer_slam.errors.InputError` for a name it does not know."""
    selected = []
    for name in names or [sequence.name for sequence in SEQUENCES]:
        sequence = known_sequence(name)
        if sequence is None:
            raise InputError(f"{name}: not one of the study's sequences; {', '.join(s.alias for s in SEQUENCES)}")
        selected.append(sequence)
    return selected


def cached_sequences() -> list[tuple[StudySequence, bool]]:
    """Every study sequence and whether all its files are in the cache."""
    cache = study_cache()
    return [(sequence, all((cache / path).is_file() for path in sequence_files(sequence))) for sequence in SEQUENCES]
