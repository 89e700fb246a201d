"""Faults during a run: a full disk, two runs on one --out, stop signals, Ctrl-C at start-up,
an unexpected error, an interrupted benchmark; and what each command imports at start-up."""

import http.server
import json
import os
import resource
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from fixtures_eval import TUM_RPY, tum_excerpt

from viewer_slam.atomic import exclusive, lock_path
from viewer_slam.cli import main

pytestmark = pytest.mark.skipif(not TUM_RPY.is_dir(), reason="shared TUM excerpt not present")

ROOT = Path(__file__).resolve().parents[2]
BIN = Path(sys.executable).parent
TMPFS_BYTES = 600 * 1024
FRAMES = 60


@pytest.fixture(scope="module")
def excerpt(tmp_path_factory) -> Path:
    return tum_excerpt(tmp_path_factory.mktemp("excerpt") / "rgbd_dataset_freiburg1_rpy", frames=FRAMES)


def python(*arguments, **options) -> subprocess.Popen:
    """A Python child that imports this tree's viewer_slam, its output captured."""
    environment = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    return subprocess.Popen(
        [sys.executable, *map(str, arguments)],
        env=environment,
        **{"stdout": subprocess.PIPE, "stderr": subprocess.PIPE, "text": True, **options},
    )


def viewslam(*arguments, **options) -> subprocess.Popen:
    return python("-m", "viewer_slam", *arguments, **options)


def verify(path: Path) -> bool:
    return subprocess.run([BIN / "rerun", "rrd", "verify", str(path)], capture_output=True).returncode == 0


@pytest.fixture
def small_disk(tmp_path):
    """A 600 KiB file system (a tmpfs when root), or None where none can be mounted."""
    mount = tmp_path / "disk"
    mount.mkdir()
    if (
        os.geteuid() != 0
        or subprocess.run(
            ["mount", "-t", "tmpfs", "-o", f"size={TMPFS_BYTES}", "tmpfs", str(mount)], capture_output=True
        ).returncode
        != 0
    ):
        yield None
        return
    yield mount
    subprocess.run(["umount", str(mount)], check=True)


def limit_file_size() -> None:
    """In the child: files may not grow beyond TMPFS_BYTES; writes past it fail (EFBIG), not kill."""
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (TMPFS_BYTES, TMPFS_BYTES))


def test_a_full_disk_is_exit_2_the_report_says_so_and_the_earlier_recording_stays(excerpt, small_disk, tmp_path):
    folder = small_disk or tmp_path / "limited"
    folder.mkdir(exist_ok=True)
    earlier = folder / "run.rrd"
    earlier.write_bytes(b"earlier recording")
    child = viewslam(
        "record",
        excerpt,
        "--out",
        earlier,
        "--pipeline",
        "rgbdslam",
        "--max-frames",
        12,
        "--quiet",
        preexec_fn=None if small_disk else limit_file_size,
    )
    out, error = child.communicate(timeout=120)
    assert child.returncode == 2, error
    assert error.count("\n") == 1 and error.startswith(f"viewslam: error: {earlier}: recording not written: ")
    if small_disk:
        assert "no space left on device" in error
    assert earlier.read_bytes() == b"earlier recording"
    report = json.loads((folder / "run.json").read_text())
    assert report["failed"] is True and "run.rrd" in report["error"]
    assert report["pipelines"]["rgbdslam"]["frames_with_pose"] > 0
    assert (
        len((folder / "run.rgbdslam.txt").read_text().splitlines())
        == report["pipelines"]["rgbdslam"]["frames_with_pose"]
    )
    assert sorted(path.name for path in folder.iterdir()) == ["run.json", "run.rgbdslam.txt", "run.rrd"]


STALLING_WRITER = """
import sys, numpy as np, rerun as rr, rerun.blueprint as rrb
from pathlib import Path
from viewer_slam.rerun_adapter.rrd_file import RecordingFile
path = Path(sys.argv[1])
recording = RecordingFile(path, path, rrb.Blueprint(rrb.Spatial3DView(origin="/")))
for frame in range(30):  # 3.6 MB, far more than the disk holds
    recording.stream.set_time("frame", sequence=frame)
    recording.stream.log("points", rr.Points3D(np.random.default_rng(frame).random((10000, 3))))
recording.close()  # at once: the flush meets the file sink's writer while it dies on the error
print(recording.error, flush=True)
"""


@pytest.mark.parametrize("attempt", range(3))
def test_closing_a_recording_on_a_full_disk_ends_with_its_error_never_a_hang(small_disk, tmp_path, attempt):
    folder = small_disk or tmp_path
    child = python("-c", STALLING_WRITER, folder / "run.rrd", preexec_fn=None if small_disk else limit_file_size)
    out, error = child.communicate(timeout=60)
    assert child.returncode in (0, 2), error  # 2: the sink stalled and the stream was abandoned
    expected = "no space left on device" if small_disk else "the file reached the process's file-size limit"
    assert out.startswith(expected), out


def test_a_second_run_on_the_same_out_says_so_and_leaves_the_first_alone(excerpt, tmp_path):
    out = tmp_path / "run.rrd"
    with exclusive([out]):  # the first run, holding its outputs
        child = viewslam("record", excerpt, "--out", out, "--quiet")
        _, error = child.communicate(timeout=120)
        assert child.returncode == 2
        assert (
            error == f"viewslam: error: {out}: another viewslam run is writing this output; wait for it or "
            f"choose another --out\n"
        )
        assert sorted(path.name for path in tmp_path.iterdir()) == [lock_path(out).name]
    assert not lock_path(out).exists()
    with exclusive([out]):  # free again once the first run is over
        pass


def test_two_runs_at_once_one_writes_one_refuses(excerpt, tmp_path):
    out = tmp_path / "run.rrd"
    runs = [
        viewslam("record", excerpt, "--out", out, "--pipeline", "rgbdslam", "--max-frames", 4, "--quiet")
        for _ in range(2)
    ]
    results = sorted((run.wait(timeout=300), run.stderr.read()) for run in runs)
    assert [code for code, _ in results] == [0, 2]
    assert "another viewslam run is writing this output" in results[1][1] and results[1][1].count("\n") == 1
    assert verify(out) and json.loads(out.with_suffix(".json").read_text())["interrupted"] is False


def record_until_frames_are_in(excerpt: Path, out: Path) -> subprocess.Popen:
    """``viewslam record`` of rgbdslam onto ``out``, once its recording holds frames."""
    child = viewslam("record", excerpt, "--out", out, "--pipeline", "rgbdslam", "--quiet")
    deadline = time.monotonic() + 120
    while not any(path.stat().st_size > 200_000 for path in out.parent.glob(f".{out.name}.*.part")):
        assert child.poll() is None and time.monotonic() < deadline
        time.sleep(0.05)
    return child


@pytest.mark.parametrize(
    "stops, gap_s",
    [
        ([signal.SIGTERM], 0),
        ([signal.SIGHUP], 0),
        ([signal.SIGTERM, signal.SIGHUP], 0.01),
        ([signal.SIGTERM, signal.SIGHUP], 0.3),
    ],
    ids=["SIGTERM", "SIGHUP", "SIGTERM-then-SIGHUP", "SIGTERM-then-SIGHUP-later"],
)
def test_sigterm_and_sighup_stop_like_ctrl_c(excerpt, tmp_path, stops, gap_s):
    out = tmp_path / "run.rrd"
    child = record_until_frames_are_in(excerpt, out)
    for stop in stops:
        child.send_signal(stop)
        time.sleep(gap_s)
    _, error = child.communicate(timeout=120)
    assert child.returncode == 130 and "Traceback" not in error
    lines = [line.split(": ", 2)[1:] for line in error.splitlines() if line]
    if gap_s < 0.1:  # signals pending together are handled in number order: which one comes first is not fixed
        assert sorted(name for name, _ in lines) == sorted(stop.name for stop in stops)
    else:  # the second comes while the run stops (said so), or once it has stopped (absorbed, nothing said)
        assert [name for name, _ in lines] == [stop.name for stop in stops][: len(lines)] and lines
    assert [what.split(" after")[0] for _, what in lines] == ["stopping", "already stopping"][: len(lines)]
    report = json.loads(out.with_suffix(".json").read_text())
    assert report["interrupted"] is True and report["failed"] is False
    poses = report["pipelines"]["rgbdslam"]["frames_with_pose"]
    assert 0 < poses < FRAMES
    assert len(out.with_name("run.rgbdslam.txt").read_text().splitlines()) == poses
    assert verify(out)


@pytest.mark.parametrize(
    "stops",
    [(signal.SIGINT, signal.SIGINT, signal.SIGINT), (signal.SIGHUP, signal.SIGINT, signal.SIGTERM)],
    ids=["Ctrl-C", "mixed"],
)
def test_a_second_stop_signal_repeats_the_request_and_a_third_aborts(stops, capsys):
    """Signals of one kind sent together reach a process as one (the kernel does not queue
    them), so the second Ctrl-C is raised here, once the first has been handled."""
    from viewer_slam.errors import Interrupted
    from viewer_slam.record.interrupt import StopRequest

    with StopRequest().installed() as stop:
        for stop_signal in stops[:2]:
            signal.raise_signal(stop_signal)
            assert stop.requested
        with pytest.raises(Interrupted):
            signal.raise_signal(stops[2])
    lines = capsys.readouterr().err.split("\n")
    assert [line.split(": ")[1:] for line in lines if line][:2] == [
        [stops[0].name, "stopping after this frame and writing what was recorded (a third stop signal aborts)"],
        [stops[1].name, "already stopping after this frame (one more stop signal aborts)"],
    ]


def test_a_third_stop_signal_aborts_and_leaves_the_earlier_outputs(excerpt, tmp_path):
    out = tmp_path / "run.rrd"
    earlier = {name: f"earlier {name}".encode() for name in ("run.rrd", "run.json", "run.rgbdslam.txt")}
    for name, content in earlier.items():
        (tmp_path / name).write_bytes(content)
    child = record_until_frames_are_in(excerpt, out)
    for stop in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        child.send_signal(stop)
        time.sleep(0.01)
    _, error = child.communicate(timeout=120)
    assert child.returncode == 130 and error.endswith("viewslam: interrupted\n") and "Traceback" not in error
    assert {path.name: path.read_bytes() for path in tmp_path.iterdir() if path.is_file()} == earlier


def test_ctrl_c_during_start_up_is_one_line_and_exit_130(excerpt, tmp_path, monkeypatch, capsys):
    import viewer_slam.runs.run_specs as selection

    def interrupted(*arguments, **options):
        signal.raise_signal(signal.SIGINT)  # Ctrl-C while the options are being checked

    monkeypatch.setattr(selection, "resolve_params", interrupted)
    assert main(["record", str(excerpt), "--out", str(tmp_path / "run.rrd"), "--quiet"]) == 130
    assert capsys.readouterr().err == "viewslam: interrupted\n"
    assert list(tmp_path.iterdir()) == []


def test_ctrl_c_while_importing_is_one_line_and_exit_130(excerpt, tmp_path):
    child = viewslam("record", excerpt, "--out", tmp_path / "run.rrd", "--quiet")
    time.sleep(1.0)  # in viewslam's imports or option checks (a signal before the interpreter has
    # loaded the entry point is Python's own)
    child.send_signal(signal.SIGINT)
    _, error = child.communicate(timeout=120)
    assert child.returncode == 130 and "Traceback" not in error and error.count("\n") <= 2, error


def test_ctrl_c_inside_a_compiled_extensions_import_is_one_line_and_exit_130(tmp_path, monkeypatch, capsys):
    import viewer_slam.runs.run_specs as selection
    from viewer_slam.errors import Interrupted

    def extension_interrupted_while_loading(*arguments, **options):
        try:
            raise Interrupted("SIGINT")
        except Interrupted as interrupt:  # what pybind11's module initialisation does with it
            raise ImportError("initialization failed") from interrupt

    monkeypatch.setattr(selection, "resolve_params", extension_interrupted_while_loading)
    monkeypatch.setenv("VIEWSLAM_LOG_DIR", str(tmp_path))
    assert main(["record", str(TUM_RPY), "--out", str(tmp_path / "run.rrd"), "--quiet"]) == 130
    assert capsys.readouterr().err == "viewslam: interrupted\n"
    assert list(tmp_path.iterdir()) == []  # no crash log


def test_an_unexpected_error_is_one_line_with_a_log_and_keeps_what_was_recorded(excerpt, tmp_path, monkeypatch, capsys):
    from viewer_slam.pipelines.rtabmap import PIPELINE as RtabMap

    def broken(self, frame):
        raise ZeroDivisionError("a bug")

    monkeypatch.setattr(RtabMap, "process", broken)
    monkeypatch.setenv("VIEWSLAM_LOG_DIR", str(tmp_path / "logs"))
    (tmp_path / "logs").mkdir()
    out = tmp_path / "run.rrd"
    assert main(["record", str(excerpt), "--out", str(out), "--max-frames", "3", "--quiet"]) == 1
    error = capsys.readouterr().err
    log = next((tmp_path / "logs").iterdir())
    assert error == f"viewslam: internal error: ZeroDivisionError: a bug; full traceback in {log}\n"
    assert "Traceback (most recent call last)" in log.read_text() and "broken" in log.read_text()
    report = json.loads(out.with_suffix(".json").read_text())  # rgbdslam ran before rtabmap failed
    assert report["failed"] is True and "a bug" in report["error"]
    assert list(report["pipelines"]) == ["rgbdslam"] and report["pipelines"]["rgbdslam"]["frames_with_pose"] == 3
    assert verify(out)


def test_an_interrupted_benchmark_writes_the_finished_rows(tmp_path, monkeypatch, capsys):
    from benchmark_fake_pipeline import MODULE, write_tum_folder

    import viewer_slam.benchmark.suite as suite
    from viewer_slam.benchmark.runner import execute_task
    from viewer_slam.pipelines import base

    monkeypatch.setitem(base.PIPELINE_MODULES, "fake", MODULE)

    def first_then_ctrl_c(tasks, executor, *, on_start, on_finish):
        on_start(tasks[0])
        on_finish(tasks[0], execute_task(tasks[0]))
        signal.raise_signal(signal.SIGTERM)

    monkeypatch.setattr(suite, "run_tasks", first_then_ctrl_c)
    folders = [write_tum_folder(tmp_path / name, frames=10) for name in ("one", "two")]
    out = tmp_path / "out"
    assert (
        main(["benchmark", *map(str, folders), "--pipeline", "fake", "--out", str(out), "--quiet", "--no-cache"]) == 130
    )
    rows = (out / "results.csv").read_text().splitlines()
    assert len(rows) == 2 and rows[1].startswith("one,fake,") and rows[1].endswith(",ok")
    printed = capsys.readouterr().out
    assert "1 of 1 task ok; interrupted with 1 not run; wrote " in printed and str(out / "results.csv") in printed


def test_benchmark_prints_its_table_with_full_numbers_when_piped(tmp_path, monkeypatch, capsys):
    from benchmark_fake_pipeline import MODULE, write_tum_folder

    from viewer_slam.pipelines import base

    monkeypatch.setitem(base.PIPELINE_MODULES, "fake", MODULE)
    folder = write_tum_folder(tmp_path / "a_sequence_with_a_long_name_indeed", frames=10)
    out = tmp_path / "out"
    assert (
        main(
            [
                "benchmark",
                str(folder),
                "--pipeline",
                "fake",
                "--out",
                str(out),
                "--quiet",
                "--no-cache",
                "--param",
                "wobble_m=0.02",
            ]
        )
        == 0
    )
    printed = capsys.readouterr().out
    row = json.loads((out / "results.json").read_text())[0]
    assert "…" not in printed and "a_sequence_with_a_long_name_indeed" in printed
    assert f"{row['ate_rmse']:.4f}" in printed and f"{row['coverage']:.1%}" in printed
    assert f"1 of 1 task ok; wrote {out / 'results.csv'}, {out / 'results.json'}, {out / 'report.md'}" in printed


def test_the_record_summary_is_not_cut_on_a_narrow_console():
    import io

    from rich.console import Console

    from viewer_slam.record.console import print_summary

    block = {
        "frames_with_pose": 1234,
        "coverage": {"ratio": 0.5},
        "ate": {"rmse": 0.123456},
        "penalized_ate": {"rmse": 1.5},
        "rpe": None,
        "loop_closures": {"accepted": 12, "rejected": 345},
        "timing": {"fps": 12.5},
    }
    stream = io.StringIO()
    print_summary(
        {"sequence": {"name": "n"}, "interrupted": False, "pipelines": {"rgbdslam": block}},
        [],
        Console(file=stream, width=30),
    )
    text = stream.getvalue()
    assert "…" not in text and "0.123" in text and "1234" in text and "12/345" in text


def test_benchmark_max_frames_cuts_the_scenario_rendered_at_its_own_length_and_renders_only_the_cut(monkeypatch):
    import viewer_slam.benchmark.plan as plan
    import viewer_slam.benchmark.runner as runner

    rendered = []

    def resolve(spec, *, frames=None, resolution=(640, 480), seed=0, first=None, progress=False):
        rendered.append((spec, frames, first))
        return Path("/scenarios") / spec

    monkeypatch.setattr(runner, "resolve_sequence", resolve)
    tasks = plan.plan_tasks(["360_kidnap"], ["rgbdslam"], max_frames=60)
    assert rendered == [("360_kidnap", None, 60)] and tasks[0].max_frames == 60


COMMANDS_WITHOUT_HEAVY_IMPORTS = {
    "help": ["--help"],
    "evaluate-help": ["evaluate", "--help"],
    "evaluate": ["evaluate", "{gt}", "{gt}"],
    "download-help": ["download", "--help"],
    "download-bad-mirror": ["download", "fr1/xyz", "--mirror", "notaurl"],
    "sequences": ["sequences"],
}


@pytest.mark.parametrize("arguments", COMMANDS_WITHOUT_HEAVY_IMPORTS.values(), ids=COMMANDS_WITHOUT_HEAVY_IMPORTS)
def test_light_commands_never_import_rerun_opencv_open3d_or_gtsam(arguments):
    groundtruth = TUM_RPY / "groundtruth.txt"
    script = (
        "import sys\nfrom viewer_slam.cli import main\ncode = main(sys.argv[1:])\n"
        "print(sorted({name.split('.')[0] for name in sys.modules} & {'rerun', 'cv2', 'open3d', 'gtsam'}))"
    )
    environment = {**os.environ, "PYTHONPATH": str(ROOT)}
    result = subprocess.run(
        [sys.executable, "-c", script, *(a.format(gt=groundtruth) for a in arguments)],
        capture_output=True,
        text=True,
        env=environment,
        timeout=120,
    )
    assert result.stdout.splitlines()[-1] == "[]", result.stderr


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="no /dev/full")
def test_a_stdout_that_cannot_take_the_output_is_one_line_and_exit_2(tmp_path, monkeypatch, capsys):
    trajectory = tmp_path / "t.txt"
    trajectory.write_text("".join(f"{k / 10:.1f} {k / 100} 0 0 0 0 0 1\n" for k in range(30)))
    with open("/dev/full", "w") as full:
        monkeypatch.setattr(sys, "stdout", full)
        assert main(["evaluate", str(trajectory), str(trajectory)]) == 2
    assert capsys.readouterr().err == "viewslam: error: stdout: cannot write: No space left on device\n"


@pytest.mark.parametrize("reason", ["Broken pipe", "Bad file descriptor"], ids=["closed-pipe", "closed-descriptor"])
def test_a_stdout_that_is_closed_is_one_line_and_exit_2(tmp_path, reason):
    trajectory = tmp_path / "t.txt"
    trajectory.write_text("".join(f"{k / 10:.1f} {k / 100} 0 0 0 0 0 1\n" for k in range(30)))
    if reason == "Broken pipe":  # `| head -c1` once head has its byte: the reader has left
        reader, writer = os.pipe()
        os.close(reader)
        child = viewslam("evaluate", trajectory, trajectory, stdout=writer)
        os.close(writer)
    else:  # `>&-`: no stdout at all
        child = viewslam("evaluate", trajectory, trajectory, stdout=subprocess.DEVNULL, preexec_fn=lambda: os.close(1))
    _, error = child.communicate(timeout=60)
    assert (child.returncode, error) == (2, f"viewslam: error: stdout: cannot write: {reason}\n")


def test_a_plugin_that_calls_sys_exit_at_import_is_that_plugins_one_line(tmp_path, monkeypatch):
    from importlib.metadata import EntryPoint

    from viewer_slam.errors import InputError
    from viewer_slam.pipelines.base import ENTRY_POINT_GROUP, load_plugin

    (tmp_path / "exits_at_import.py").write_text("import sys\nsys.exit(3)\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(
        InputError,
        match=r"^pipeline plugin 'quitter' \(exits_at_import:Pipeline\): cannot be "
        r"imported: called sys.exit\(3\)$",
    ):
        load_plugin(EntryPoint("quitter", "exits_at_import:Pipeline", ENTRY_POINT_GROUP))


def test_a_pipeline_that_calls_sys_exit_mid_run_is_its_failure_and_the_others_are_kept(tmp_path, monkeypatch, capsys):
    from benchmark_fake_pipeline import MODULE, write_tum_folder

    from viewer_slam.pipelines import base

    monkeypatch.setitem(base.PIPELINE_MODULES, "fake", MODULE)
    monkeypatch.setitem(base.PIPELINE_MODULES, "quitter", MODULE)
    folder = write_tum_folder(tmp_path / "tiny", frames=4)
    config = tmp_path / "c.toml"
    config.write_text('[quitter]\nfail = "sys.exit"\n')
    out = tmp_path / "run.rrd"
    assert (
        main(
            ["record", str(folder), "--pipeline", "fake,quitter", "--config", str(config), "--out", str(out), "--quiet"]
        )
        == 2
    )
    error = capsys.readouterr().err
    assert (
        error.startswith("viewslam: error: pipeline quitter called sys.exit(5); the frames before it are recorded in")
        and error.count("\n") == 1
    )
    report = json.loads(out.with_suffix(".json").read_text())
    assert report["failed"] is True and report["pipelines"]["fake"]["frames_with_pose"] == 4
    assert verify(out)


def test_a_rerun_on_the_same_out_leaves_no_file_of_the_earlier_run_behind(tmp_path, monkeypatch):
    from benchmark_fake_pipeline import MODULE, write_tum_folder

    from viewer_slam.pipelines import base

    monkeypatch.setitem(base.PIPELINE_MODULES, "fake", MODULE)
    monkeypatch.setitem(base.PIPELINE_MODULES, "other", MODULE)
    folder = write_tum_folder(tmp_path / "tiny", frames=3)
    out = tmp_path / "out" / "run.rrd"
    notes = out.with_name("run.notes.txt")  # not the run's: stays
    for pipelines in ("fake,other", "fake"):
        assert main(["record", str(folder), "--pipeline", pipelines, "--out", str(out), "--quiet"]) == 0
        notes.write_text("mine\n")
    report = json.loads(out.with_suffix(".json").read_text())
    assert list(report["pipelines"]) == ["fake"]
    assert sorted(path.name for path in out.parent.iterdir()) == [
        "run.fake.txt",
        "run.json",
        "run.notes.txt",
        "run.rrd",
    ]


def test_evaluate_writes_its_json_and_plot_together_or_neither(tmp_path, monkeypatch, capsys):
    import errno

    import viewer_slam.evaluation.plot as plot

    def full_disk(path, *arguments, **options):
        Path(path).write_bytes(b"half a picture")
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(plot, "plot_evaluation", full_disk)
    trajectory = tmp_path / "t.txt"
    trajectory.write_text("".join(f"{k / 10:.1f} {k / 100} 0 0 0 0 0 1\n" for k in range(30)))
    report, picture = tmp_path / "e.json", tmp_path / "e.png"
    report.write_text("earlier\n")
    assert main(["evaluate", str(trajectory), str(trajectory), "--json", str(report), "--plot", str(picture)]) == 2
    assert capsys.readouterr().err == f"viewslam: error: {picture}: cannot write: No space left on device\n"
    assert report.read_text() == "earlier\n" and sorted(path.name for path in tmp_path.iterdir()) == ["e.json", "t.txt"]


def test_a_disk_too_full_to_start_a_recording_is_one_line_before_rerun_writes(excerpt, tmp_path, capsys):
    mount = tmp_path / "disk"
    mount.mkdir()
    if (
        os.geteuid() != 0
        or subprocess.run(
            ["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(mount)], capture_output=True
        ).returncode
        != 0
    ):
        pytest.skip("no small file system can be mounted here")
    try:
        out = mount / "run.rrd"
        assert main(["record", str(excerpt), "--pipeline", "rgbdslam", "--out", str(out), "--quiet"]) == 2
        error = capsys.readouterr().err
        assert error.startswith(f"viewslam: error: {out}: cannot write the recording: no space left on device (")
        assert error.count("\n") == 1 and list(mount.iterdir()) == []
    finally:
        subprocess.run(["umount", str(mount)], check=True)


def test_record_renders_a_scenario_only_up_to_the_last_frame_it_reads(monkeypatch, tmp_path):
    from viewer_slam.dataset import sources
    from viewer_slam.errors import InputError
    from viewer_slam.record.command import record

    asked = []

    def resolve(spec, *, first=None, progress=False, **sizes):
        asked.append((spec, first, progress))
        raise InputError("stop here")

    monkeypatch.setattr(sources, "resolve_sequence", resolve)
    for stride, quiet in ((1, True), (3, False)):
        with pytest.raises(InputError, match="stop here"):
            record("360_kidnap", max_frames=4, stride=stride, quiet=quiet, out=tmp_path / "x.rrd")
    assert asked == [("360_kidnap", 4, False), ("360_kidnap", 10, True)]  # frames 0, 3, 6, 9


# Every writer: a full disk names the path written, exit 2, nothing earlier lost.


def limit_file_size_to(size: int):
    """For a child: files may not grow beyond ``size`` bytes; writes past it fail (EFBIG), not kill."""

    def limit() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (size, size))

    return limit


@pytest.fixture(scope="module")
def recorded_report(tmp_path_factory) -> Path:
    """The report (and trajectory) of a 4-frame run of the scripted pipeline."""
    from benchmark_fake_pipeline import recorded_report as record_fake

    return record_fake(tmp_path_factory.mktemp("run"))


@pytest.mark.parametrize("option, name", [("--out", "d.rrd"), ("--json", "d.json")])
def test_diff_on_a_full_disk_names_its_output_and_keeps_the_earlier_one(recorded_report, tmp_path, option, name):
    target = tmp_path / name
    target.write_bytes(b"earlier")
    child = viewslam(
        "diff",
        recorded_report,
        recorded_report,
        option,
        target,
        preexec_fn=limit_file_size_to(1000 if name.endswith(".json") else 100_000),
    )
    _, error = child.communicate(timeout=120)
    assert child.returncode == 2 and error.count("\n") == 1, error
    assert error.startswith(f"viewslam: error: {target}: ")
    assert target.read_bytes() == b"earlier" and sorted(path.name for path in tmp_path.iterdir()) == [name]


def test_synth_on_a_full_disk_names_its_folder_in_one_line_and_keeps_the_earlier_render(small_disk, tmp_path):
    folder = small_disk or tmp_path / "limited"
    out = folder / "scene"
    out.mkdir(parents=True)
    (out / "rgb.txt").write_text("earlier\n")
    child = viewslam(
        "synth",
        "360_kidnap",
        "--out",
        out,
        "--frames",
        60,
        "--resolution",
        "160x120",
        "--force",
        preexec_fn=None if small_disk else limit_file_size_to(20_000),
    )
    _, error = child.communicate(timeout=300)
    assert child.returncode == 2 and error.count("\n") == 1, error  # no progress line above it
    assert error.startswith(f"viewslam: error: {out}: cannot write: ")
    assert sorted(path.name for path in folder.iterdir()) == ["scene"] and (out / "rgb.txt").read_text() == "earlier\n"


def test_download_on_a_full_disk_names_the_file_written(tmp_path):
    mirror = tmp_path / "mirror"
    (mirror / "freiburg1").mkdir(parents=True)
    (mirror / "freiburg1" / "rgbd_dataset_freiburg1_xyz.tgz").write_bytes(os.urandom(2_000_000))
    child = viewslam(
        "download",
        "fr1/xyz",
        "--dest",
        tmp_path / "dest",
        "--mirror",
        f"file://{mirror}",
        preexec_fn=limit_file_size_to(600_000),
    )
    _, error = child.communicate(timeout=120)
    part = tmp_path / "dest" / ".rgbd_dataset_freiburg1_xyz.tgz.part"
    assert child.returncode == 2 and error == f"viewslam: error: {part}: cannot write: File too large\n"


# Stop signals: the second is absorbed while the first is honoured, the third aborts; one line.


def rendering(out: Path, frames: int = 1000) -> subprocess.Popen:
    """``viewslam synth`` into ``out``, with its progress line, once it has written frames."""
    child = viewslam("synth", "360_kidnap", "--out", out, "--frames", frames, "--resolution", "64x48")
    deadline = time.monotonic() + 120
    while len(list(out.parent.glob(f".{out.name}.*/rgb/*.png"))) < 3:
        assert child.poll() is None and time.monotonic() < deadline
        time.sleep(0.02)
    return child


STOPS = {
    "SIGTERM": [signal.SIGTERM],
    "SIGINT": [signal.SIGINT],
    "SIGTERM-then-SIGHUP": [signal.SIGTERM, signal.SIGHUP],
    "three": [signal.SIGINT, signal.SIGHUP, signal.SIGTERM],
}


@pytest.mark.parametrize("stops", STOPS.values(), ids=STOPS.keys())
def test_synth_stops_on_any_stop_signals_with_one_line_and_leaves_nothing(tmp_path, stops):
    out = tmp_path / "scene"
    child = rendering(out)
    for stop in stops:
        child.send_signal(stop)
        time.sleep(0.3)
    _, error = child.communicate(timeout=120)
    assert (child.returncode, error) == (130, "viewslam: interrupted\n")
    assert list(tmp_path.iterdir()) == []  # neither the folder nor its staging


class TricklingHandler(http.server.BaseHTTPRequestHandler):
    """Sends 8 MB of an archive in 64 KB pieces, 20 ms apart: a download that takes a while."""

    def do_GET(self):
        self.send_response(200)
        self.send_header("Content-Length", str(128 * 65536))
        self.end_headers()
        for _ in range(128):
            try:
                self.wfile.write(bytes(65536))
            except OSError:  # the client left
                return
            time.sleep(0.02)

    def log_message(self, *args):
        pass


@pytest.mark.parametrize("stops", [[signal.SIGTERM], [signal.SIGTERM, signal.SIGHUP]], ids=["SIGTERM", "two"])
def test_download_stops_on_stop_signals_with_one_line_and_keeps_what_arrived(tmp_path, stops):
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), TricklingHandler)
    threading.Thread(target=server.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True).start()
    try:
        child = viewslam(
            "download", "fr1/xyz", "--dest", tmp_path, "--mirror", f"http://127.0.0.1:{server.server_address[1]}"
        )
        part = tmp_path / ".rgbd_dataset_freiburg1_xyz.tgz.part"
        deadline = time.monotonic() + 60
        while not part.exists() or part.stat().st_size < 200_000:
            assert child.poll() is None and time.monotonic() < deadline
            time.sleep(0.02)
        for stop in stops:
            child.send_signal(stop)
            time.sleep(0.3)
        _, error = child.communicate(timeout=60)
    finally:
        server.shutdown()
        server.server_close()
    assert (child.returncode, error) == (130, "viewslam: interrupted\n")
    assert part.stat().st_size >= 200_000  # kept for the next download to resume


def test_the_command_line_absorbs_a_second_stop_signal_and_aborts_on_the_third(capsys):
    from viewer_slam import stopping
    from viewer_slam.errors import Interrupted

    with stopping.installed():
        with pytest.raises(Interrupted, match="SIGTERM"):
            signal.raise_signal(signal.SIGTERM)
        signal.raise_signal(signal.SIGHUP)  # while the first is honoured: absorbed
        with pytest.raises(Interrupted, match="SIGINT"):
            signal.raise_signal(signal.SIGINT)
    assert capsys.readouterr().err == ""


def test_a_loop_at_safe_points_stops_only_where_it_checks():
    from viewer_slam import stopping
    from viewer_slam.errors import Interrupted

    with stopping.installed(), stopping.at_safe_points() as stop:
        signal.raise_signal(signal.SIGHUP)
        assert stop.requested
        signal.raise_signal(signal.SIGTERM)  # absorbed
        with pytest.raises(Interrupted, match="SIGHUP"):
            stop.check()
