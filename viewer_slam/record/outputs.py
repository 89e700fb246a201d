"""Where `viewslam record` writes (the recording, ``NAME.json`` and ``NAME.<run>.txt`` beside it),
checked before any work starts and written under temporary names."""

from pathlib import Path

from ..atomic import check_writable, refuse_inputs_as_outputs
from ..documents import read_json
from ..errors import InputError
from ..pipelines.base import RUN_NAME

DEMO_OUT = Path("recordings/demo.rrd")


def output_path(sequence: str | None, out: Path | None) -> Path:
    """``--out``, else ``recordings/<sequence name>.rrd`` (``recordings/demo.rrd`` for the demo;
    a ROS 1 bag's name without ``.bag``)."""
    if out is not None:
        return Path(out)
    if sequence is None:
        return DEMO_OUT
    path = Path(sequence.rstrip("/"))
    return Path("recordings") / f"{path.stem if path.suffix == '.bag' else path.name}.rrd"


def check_outputs(out: Path, pipelines: list[str], inputs: dict[Path, str] | None = None) -> None:
    """Fail now, not after an hour of processing, if the recording or a file beside it cannot be
    written, or would replace one of the ``inputs`` (path -> how it was given)."""
    if out.suffix != ".rrd":
        raise InputError.at(out, "the recording must have the .rrd extension")
    if out.is_dir():
        raise InputError.at(out, "is a folder; --out takes a file name ending in .rrd")
    report, trajectories = report_paths(out, pipelines)
    refuse_inputs_as_outputs({path: "--out" for path in (out, report, *trajectories.values())}, inputs or {})
    for path in (out, report, *trajectories.values()):
        check_writable(path)


def report_paths(out: Path, pipelines: list[str]) -> tuple[Path, dict[str, Path]]:
    """``NAME.json`` and ``NAME.<pipeline>.txt`` beside ``NAME.rrd``."""
    return out.with_suffix(".json"), {name: out.with_name(f"{out.stem}.{name}.txt") for name in pipelines}


def earlier_trajectories(out: Path) -> list[Path]:
    """The trajectory files of the run recorded at ``out`` before, as its report lists them (none
    when it has no readable report)."""
    try:
        pipelines = read_json(out.with_suffix(".json"), "the earlier report")["pipelines"]
        return list(report_paths(out, [name for name in pipelines if RUN_NAME.fullmatch(name)])[1].values())
    except (InputError, KeyError, TypeError):
        return []
