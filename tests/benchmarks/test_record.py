"""benchmarks.record: what a recording costs, on a few frames (the figures of docs are 200 and 2,500)."""

import json

from benchmarks import record


def test_size_time_and_memory_of_a_short_recording(tiny_scene, monkeypatch, capsys):
    monkeypatch.setattr(record, "SEQUENCE_BLOCKS", {})  # nothing written into the docs
    assert record.main(["--sequence", str(tiny_scene), "--frames", "4", "--repeats", "1", "--memory-frames", "6"]) == 0
    results = json.loads(capsys.readouterr().out)
    assert results["frames"] == 4 and len(results["wall_ratios"]) == 1
    assert 0 < results["recorder_s"] < results["record_wall_s"]
    assert 1 < results["kib_per_frame"] < 1000
    memory = results["memory"]
    assert memory["frames"] == 6 and 0.1 < memory["peak_rss_gib"] < 3
    assert set(memory["fps"]) == {"rgbdslam", "rtabmap"}
    table = record.table(results)
    assert "| size, 4 frames, both pipelines |" in table and "peak RSS, 6 frames" in table
