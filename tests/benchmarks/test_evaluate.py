"""benchmarks.evaluate: viewslam's ATE and RPE beside evo's on the same trajectories."""

from benchmarks import evaluate


def test_the_numbers_equal_evos(capsys):
    assert evaluate.main(["--poses", "500", "--repeats", "1"]) == 0
    printed = capsys.readouterr().out
    assert "500 poses, median of 1 runs" in printed
    assert printed.rstrip().endswith("numbers equal")


def test_a_different_estimate_is_told_apart():
    groundtruth, estimate = evaluate.trajectories(300, seed=0)
    _, other = evaluate.trajectories(300, seed=1)
    assert evaluate.ours(groundtruth, estimate)["pairs"] == 300
    assert evaluate.ours(groundtruth, other)["ate"] > 10 * evaluate.ours(groundtruth, estimate)["ate"]
