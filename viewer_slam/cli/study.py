"""`viewslam study`: the seed study replayed from its author's own runs, published beside reproduced."""

import sys
from pathlib import Path

import typer

from ..errors import InputError
from .app import app
from .options import QUIET_HELP


@app.command()
def study(
    sequences: list[str] = typer.Argument(None, help="Study sequences to replay (TUM name, fr2/360_kidnap or the "
                                                     "author's folder); default: all seven."),
    out: Path = typer.Option(Path("study-results"), help="Folder for results.json, report.md and the charts."),
    mirror: str = typer.Option(None, help="Base URL holding the author's repository's files (default: "
                                          "$VIEWSLAM_STUDY_MIRROR, else raw.githubusercontent.com at the pinned "
                                          "commit)."),
    record: bool = typer.Option(False, "--record", help="Also write OUT/<sequence>.rrd: both runs against the "
                                                        "groundtruth, as `record --groundtruth` records trajectory "
                                                        "files (with its report and trajectories beside it)."),
    list_only: bool = typer.Option(False, "--list", help="List the study's sequences and which are cached."),
    quiet: bool = typer.Option(False, "--quiet", help=QUIET_HELP),
) -> None:
    """Fetch the study's runs (SHA-256 checked), score them as the study did and with coverage, and report."""
    from ..study.fetch import check_mirror, fetch, study_cache
    from ..study.manifest import CHARTS, SEQUENCES, known_sequence, sequence_files

    selected = []
    for name in sequences or [sequence.name for sequence in SEQUENCES]:
        sequence = known_sequence(name)
        if sequence is None:
            raise InputError(f"{name}: not one of the study's sequences; "
                             f"{', '.join(s.alias for s in SEQUENCES)}")
        selected.append(sequence)
    cache = study_cache()
    if list_only:
        for sequence in SEQUENCES:
            cached = all((cache / path).is_file() for path in sequence_files(sequence))
            typer.echo(f"{sequence.alias:<42} {sequence.folder:<36} {'cached' if cached else ''}".rstrip())
        return
    base = check_mirror(mirror)
    out.mkdir(parents=True, exist_ok=True) if not out.exists() else None
    if not out.is_dir():
        raise InputError.at(out, "is not a folder; --out takes a folder")
    files = {}
    for path in list(CHARTS) + [path for sequence in selected for path in sequence_files(sequence)]:
        files[path] = fetch(path, base, cache, progress=not quiet)

    from ..study.replay import replay
    from ..study.report import write_all

    runs, found = replay(files, selected)
    command = "viewslam study " + " ".join(sys.argv[2:]) if sys.argv[1:2] == ["study"] else "viewslam study"
    written = write_all(out, runs, found, base, command)
    if record:
        from ..geometry.trajectory_formats import TrajectoryFormat
        from ..record.files import record_trajectory_files
        from ..study.manifest import SYSTEMS, groundtruth_path, poses_path

        for sequence in selected:
            recorded = record_trajectory_files(
                files[groundtruth_path(sequence)][0],
                [(system.name, files[poses_path(sequence, system)][0]) for system in SYSTEMS],
                out / f"{sequence.name}.rrd", format=TrajectoryFormat.TUM, name=sequence.name)
            written.extend(recorded.written)
    from ..study.report import table

    typer.echo(table(runs))
    typer.echo(f"{len(found)} discrepancies between the published figures and the runs:")
    for entry in found:
        typer.echo(f"  {entry['text']}")
    for output in written:
        typer.echo(f"wrote {output}", err=True)
