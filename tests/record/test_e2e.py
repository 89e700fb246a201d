"""`viewslam record` end to end: both real pipelines on a short synthetic kidnap scenario.

The recording is read back with Rerun's own reader and verified with `rerun rrd verify`,
and a second run is interrupted with SIGINT (test_viewer_recordings renders recordings in
the real viewer).
"""

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from rerun.chunk import RrdReader

from viewer_slam.cli import main
from viewer_slam.dataset.synth import cached_scenario
from viewer_slam.geometry.trajectory import read_tum
from viewer_slam.rerun_adapter import layout

pytestmark = pytest.mark.slow

BIN = Path(sys.executable).parent
PIPELINES = ("rgbdslam", "rtabmap")
FRAMES = 90


@pytest.fixture(scope="module")
def scenario(tmp_path_factory) -> Path:
    with pytest.MonkeyPatch.context() as monkeypatch:
        monkeypatch.setenv("VIEWSLAM_CACHE", str(tmp_path_factory.mktemp("cache")))
        return cached_scenario("360_kidnap", frames=FRAMES, resolution=(320, 240))


@pytest.fixture(scope="module")
def recording(scenario, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("record") / "kidnap.rrd"
    assert main(["record", str(scenario), "--out", str(out), "--quiet"]) == 0
    return out


def chunks(path: Path) -> list:
    return list(RrdReader(path).stream().to_chunks())


def logged(path: Path, entity: str, column: str) -> list[tuple[int, list]]:
    """(frame, values) of every row of ``column`` at ``entity`` on the frame timeline, by frame."""
    rows = []
    for chunk in chunks(path):
        if chunk.entity_path == entity and not chunk.is_static:
            batch = chunk.to_record_batch().to_pydict()
            rows += [(frame, value) for frame, value in zip(batch["frame"], batch.get(column, [])) if value is not None]
    return sorted(rows, key=lambda row: row[0])


def frames_logged(path: Path, entity: str, column: str) -> list[int]:
    return [frame for frame, _ in logged(path, entity, column)]


def verify(path: Path) -> subprocess.CompletedProcess:
    return subprocess.run([BIN / "rerun", "rrd", "verify", str(path)], capture_output=True, text=True)


def test_the_recording_verifies_and_holds_the_layout(recording):
    assert verify(recording).returncode == 0
    summary = RrdReader(recording).store().summary()
    entities = {line.split()[0] for line in summary.splitlines()}
    expected = {"/world/groundtruth", "/camera/image"}
    for name in PIPELINES:
        expected |= {
            f"/{path}"
            for path in (
                layout.world(name),
                layout.camera(name),
                layout.trajectory(name),
                layout.keyframes(name),
                layout.map_cloud(name),
                layout.matches(name),
                layout.text_log(name),
            )
        }
        expected |= {
            f"/{layout.metric(name, series)}"
            for series in ("ate", "rpe_trans", "rpe_rot", "coverage", "inliers", "features", "tracking_state")
        }
    assert sorted(expected - entities) == []


def test_each_ate_series_has_a_row_per_frame_with_a_pose(recording, scenario):
    stamps = np.loadtxt(scenario / "rgb.txt", usecols=0)[:FRAMES]
    for name in PIPELINES:
        trajectory = read_tum(recording.with_name(f"kidnap.{name}.txt"))
        posed_frames = np.searchsorted(stamps, trajectory.timestamps - 1e-6)
        assert np.allclose(stamps[posed_frames], trajectory.timestamps, atol=1e-6)
        ate_frames = frames_logged(recording, f"/{layout.metric(name, 'ate')}", "Scalars:scalars")
        assert ate_frames == posed_frames.tolist()


def test_edges_are_counted_by_kind_and_only_loops_are_loop_closures(recording):
    report = json.loads(recording.with_suffix(".json").read_text())
    for name, block in report["pipelines"].items():
        assert set(block["edges"]) == {"sequential", "local", "loop"}
        assert block["edges"]["loop"] == block["loop_closures"]["accepted"]
        assert block["edges"]["sequential"] >= min(block["keyframes"] - 1, 1)  # keyframes are linked
        # A 3-second clip cannot leave the recent window (5 s), so no edge of it closes a loop.
        assert block["loop_closures"]["accepted"] == 0
        texts = [
            text for _, values in logged(recording, f"/{layout.text_log(name)}", "TextLog:text") for text in values
        ]
        assert not any("loop closure" in text and "accepted" in text for text in texts)


def test_sigint_stops_cleanly_with_a_valid_partial_recording(scenario, tmp_path):
    out = tmp_path / "stopped.rrd"
    process = subprocess.Popen(
        [BIN / "viewslam", "record", str(scenario), "--out", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 120
    # The recording grows under a temporary name beside its target until the run ends.
    while (
        not any(part.stat().st_size >= 256 * 1024 for part in tmp_path.glob(".stopped.rrd.*.part"))
        and time.monotonic() < deadline
    ):
        assert process.poll() is None, process.communicate()
        time.sleep(0.2)
    assert not out.exists()
    process.send_signal(signal.SIGINT)
    stdout, stderr = process.communicate(timeout=120)
    assert process.returncode == 130, stderr
    assert "stopping after this frame" in stderr and "Traceback" not in stderr
    assert verify(out).returncode == 0
    report = json.loads(out.with_suffix(".json").read_text())
    assert report["interrupted"] is True
    assert list(report["pipelines"]) == ["rgbdslam"]  # the second pipeline never started
    trajectory = read_tum(out.with_name("stopped.rgbdslam.txt"))
    assert 0 < len(trajectory) < FRAMES
    assert frames_logged(out, f"/{layout.metric('rgbdslam', 'ate')}", "Scalars:scalars")
