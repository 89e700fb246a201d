"""Every command's help reads as a command line is typed: a flag stands bare (it takes no value),
an option that takes one shows the value's type, and the top-level help names the options as
they are spelt now."""

import typer.core
import typer.main

from viewer_slam.cli import main
from viewer_slam.cli.app import app


def help_of(capsys, *command: str) -> str:
    assert main([*command, "--help"]) == 0
    return capsys.readouterr().out


def commands(capsys) -> list[str]:
    help_of(capsys)  # registers every command, as the entry point does
    group = typer.main.get_command(app)
    assert isinstance(group, typer.core.TyperGroup)
    return sorted(group.commands)


def test_every_command_is_listed(capsys):
    assert {"benchmark", "diff", "evaluate", "record", "study", "synth", "view"} <= set(commands(capsys))


def test_no_help_shows_a_value_type_beside_a_flag(capsys):
    for command in ["", *commands(capsys)]:
        text = help_of(capsys, *command.split())
        assert "<bool>" not in text, command
        help_line = next(line for line in text.splitlines() if "--help" in line)
        assert "<" not in help_line, (command, help_line)


def test_options_that_take_a_value_still_show_its_type(capsys):
    text = help_of(capsys, "record")
    seed_line = next(line for line in text.splitlines() if "--seed" in line)
    assert "<int range>" in seed_line
    spawn_line = next(line for line in text.splitlines() if "--spawn" in line)
    assert "<" not in spawn_line


def test_top_level_help_names_benchmark_pipeline_not_the_old_spelling(capsys):
    assert "--pipelines" not in help_of(capsys)
    assert "--pipelines" not in help_of(capsys, "benchmark")
