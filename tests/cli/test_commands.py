import subprocess
import sys


def viewslam(*args):
    return subprocess.run([sys.executable, "-m", "viewer_slam", *args], capture_output=True, text=True, timeout=120)


def test_bare_command_prints_help():
    result = viewslam()
    assert result.returncode == 0
    assert "Usage" in result.stdout


def test_unknown_command_is_one_line_and_exit_2():
    result = viewslam("frobnicate")
    assert result.returncode == 2
    assert result.stderr.strip().splitlines() == ["viewslam: error: No such command 'frobnicate'."]
    assert "Traceback" not in result.stderr


def test_every_documented_command_is_registered():
    result = viewslam("--help")
    for command in ("record", "evaluate", "synth", "benchmark", "download", "sequences", "view"):
        assert command in result.stdout, command
