"""`viewslam record` carries each loss's cause into the report, the recording and the summary."""

import json

import numpy as np
import pytest
from rerun.chunk import RrdReader

from viewer_slam.cli import main
from viewer_slam.dataset.synth.generate import cached_scenario
from viewer_slam.rerun_adapter import layout
from viewer_slam.rerun_adapter.fit import CONTINUATION

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    out = tmp_path_factory.mktemp("out") / "kidnap.rrd"
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("VIEWSLAM_CACHE", str(tmp_path_factory.mktemp("cache")))
        scenario = cached_scenario("360_kidnap", frames=120, resolution=(320, 240), seed=0)
        assert (
            main(
                [
                    "record",
                    str(scenario),
                    "--pipeline",
                    "rtabmap",
                    "--param",
                    "Rtabmap/DetectionRate=5",
                    "--param",
                    "Odom/ResetCountdown=5",
                    "--out",
                    str(out),
                    "--quiet",
                ]
            )
            == 0
        )
        info = json.loads((scenario / "scenario.json").read_text())
    return out, info


def test_the_report_names_the_cause_of_each_loss(recorded):
    out, info = recorded
    losses = json.loads(out.with_suffix(".json").read_text())["pipelines"]["rtabmap"]["tracking_lost"]
    assert len(losses) == len(info["covered_intervals"])
    for loss in losses:
        assert loss["cause"] == "sensor blocked" == loss["causes"][0]
        assert loss["evidence"]["valid_depth_share"] == 0.0
        assert loss["text"].startswith("rtabmap lost at ") and "sensor blocked (colour 100% uniform" in loss["text"]


def test_the_recording_logs_the_cause_at_each_loss_and_the_recovery(recorded):
    out, _ = recorded
    losses = json.loads(out.with_suffix(".json").read_text())["pipelines"]["rtabmap"]["tracking_lost"]
    states, lines = [], []
    for chunk in RrdReader(out).stream().to_chunks():
        if chunk.is_static:
            continue
        batch = chunk.to_record_batch().to_pydict()
        if chunk.entity_path == f"/{layout.metric('rtabmap', 'cause')}":
            states += zip(batch["frame"], batch["StateChange:state"])
        elif chunk.entity_path == f"/{layout.text_log('rtabmap')}":
            lines += [text[0] for text in batch.get("TextLog:text", []) if text]
    causes = sorted((frame, state[0]) for frame, state in states)
    assert [frame for frame, state in causes if state == "sensor blocked"] == [loss["frame"] for loss in losses]
    assert all(later[1] == "tracking" for earlier, later in zip(causes, causes[1:]) if earlier[1] != "tracking")
    text = " ".join(line.removeprefix(CONTINUATION) for line in lines)  # a message's rows joined back
    assert all(f"{loss['text']}; the pipeline: " in text for loss in losses)


def test_the_summary_prints_the_causes(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("VIEWSLAM_CACHE", str(tmp_path / "cache"))
    scenario = cached_scenario("360_kidnap", frames=40, resolution=(320, 240), seed=0)
    assert main(["record", str(scenario), "--pipeline", "rtabmap", "--out", str(tmp_path / "k.rrd")]) == 0
    losses = json.loads((tmp_path / "k.json").read_text())["pipelines"]["rtabmap"]["tracking_lost"]
    printed = capsys.readouterr().out
    assert losses and all(loss["text"] in printed for loss in losses)


def test_a_sink_that_stalls_never_holds_the_causes_back(tmp_path):
    """The flush before the causes waits a bounded time; one that fails still lets them be logged."""
    import rerun as rr

    from viewer_slam.diagnosis import Cause, FrameSignals
    from viewer_slam.rerun_adapter import loss_causes

    stream = rr.RecordingStream("viewslam-test")
    stream.save(tmp_path / "causes.rrd")
    waits = []

    def stalled(*, timeout_sec):
        waits.append(timeout_sec)
        raise RuntimeError("flush timed out")

    stream.flush = stalled
    logged = []
    stream.send_columns = lambda path, **columns: logged.append(path)
    loss = {"frame": 3, "timestamp": 0.3, "cause": Cause.TOO_FEW_FEATURES.value, "text": "lost", "reason": "few"}
    columns = {name: np.zeros(5) for name in FrameSignals.__dataclass_fields__}
    signals = FrameSignals(
        **{
            **columns,
            "frame_indices": np.arange(5),
            "timestamps": np.arange(5) / 10,
            "tracked": np.array([True, True, True, False, True]),
        }
    )
    loss_causes.log_loss_causes(stream, "rgbdslam", [loss], signals)
    assert waits == [loss_causes.FLUSH_WAIT_S] and layout.text_log("rgbdslam") in logged
    del stream.flush
    stream.disconnect()
