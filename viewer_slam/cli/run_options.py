"""The options that choose and set up the runs, declared once for `record` and `benchmark`."""

from pathlib import Path
from typing import Annotated

import typer

from ..geometry.trajectory_formats import TrajectoryFormat
from ..seeds import SEED_MAX

PIPELINE_HELP = (
    "Pipeline to run: rgbdslam, rtabmap, both or a plugin pipeline (`viewslam pipelines` lists them); "
    "repeatable or comma-separated. Default: both, or none beside --estimate."
)
ESTIMATE_HELP = (
    "Another system's trajectory replayed as a run called NAME, e.g. orbslam3=CameraTrajectory.txt "
    "(TUM, KITTI poses on the sequence's frame stamps, EuRoC CSV, or an RTAB-Map database, whose maps, "
    "loop closures and statistics come along); repeatable. With estimates, "
    "no built-in pipeline runs unless --pipeline names some."
)

Pipelines = Annotated[list[str] | None, typer.Option("--pipeline", help=PIPELINE_HELP, show_default=False)]
Estimates = Annotated[list[str] | None, typer.Option("--estimate", metavar="NAME=FILE", help=ESTIMATE_HELP)]
Format = Annotated[
    TrajectoryFormat | None,
    typer.Option("--format", help="Format of every --estimate file (default: detected; stderr says which was used)."),
]
Params = Annotated[
    list[str] | None,
    typer.Option("--param", help="Pipeline parameter under its original name, KEY=VALUE (repeatable)."),
]
Config = Annotated[
    Path | None, typer.Option("--config", help="TOML file of parameters (flat, or one table per pipeline).")
]
Seed = Annotated[int, typer.Option("--seed", min=0, max=SEED_MAX, help="Seed of every random choice.")]
