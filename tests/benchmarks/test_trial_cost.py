"""benchmarks.trial_cost: every planned task of a benchmark timed and weighed, into a figure block."""

from benchmarks import trial_cost
from benchmarks.figures import written


def test_the_cost_of_each_trial_into_the_block(tmp_path, monkeypatch):
    document = tmp_path / "benchmark.md"
    document.write_text("# Benchmark\n<!-- figures: trial-cost -->\nold\n<!-- /figures: trial-cost -->\n")
    monkeypatch.setattr(trial_cost, "DOCUMENT", document)
    arguments = ["360_kidnap", "--scenario-frames", "6", "--resolution", "160x120", "--trials", "1"]
    assert trial_cost.main(arguments) == 0
    block = written(document.read_text(), "trial-cost")
    assert block.startswith("Made by `python -m benchmarks.trial_cost 360_kidnap --scenario-frames 6 ")
    rows = [line.split("|")[1:-1] for line in block.splitlines() if line.startswith("| 360_kidnap")]
    assert [row[1].strip() for row in rows] == ["rgbdslam", "rtabmap"]
    assert all(row[3].strip() == "6" and float(row[4]) >= 0 and float(row[7]) > 0 for row in rows)  # frames, CPU s, kB
