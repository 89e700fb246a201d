"""The typer application that every command module registers on."""

import typer

app = typer.Typer(
    name="viewslam",
    help="A 3D visual debugger and benchmark for RGB-D SLAM, recorded into Rerun.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
