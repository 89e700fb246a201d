"""benchmarks.rgbdslam: speed per detector, and memory over a long ping-pong stream."""

from benchmarks import rgbdslam


def test_speed_per_detector(tiny_scene, capsys):
    assert (
        rgbdslam.main(
            [
                "speed",
                "--sequence",
                str(tiny_scene),
                "--frames",
                "5",
                "--detectors",
                "ORB",
                "--param",
                "max_keypoints=300",
            ]
        )
        == 0
    )
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == f"sequence {tiny_scene.name}: 5 frames, 320x240"
    row = [cell.strip() for cell in lines[3].split("|")[1:-1]]
    assert row[0] == "ORB" and len(row) == len(lines[1].split("|")) - 2
    assert 0 <= float(row[-3]) < 0.05  # ATE RMSE, metres


def test_memory_over_a_stream_longer_than_the_sequence(tiny_scene, capsys):
    assert rgbdslam.main(["memory", "--sequence", str(tiny_scene), "--frames", "14"]) == 0
    printed = capsys.readouterr().out
    assert printed.startswith(f"14 frames ({tiny_scene.name} forwards and backwards)")
    assert "peak RSS" in printed
