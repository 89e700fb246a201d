"""benchmarks.synth: the contact sheet of the scenarios (the speed measurement renders whole runs)."""

import cv2

from benchmarks import synth


def test_the_contact_sheet_of_one_scenario(tmp_path, capsys):
    sheet = tmp_path / "sheet.png"
    assert (
        synth.main(["--no-speed", "--scenarios", "360_kidnap", "--resolution", "160x120", "--sheet", str(sheet)]) == 0
    )
    image = cv2.imread(str(sheet))
    assert image.shape == (22 + 180, 6 * 240, 3)  # a label row, then 3 frames of colour beside depth, 240 px each
    assert capsys.readouterr().out == f"contact sheet: {sheet}\n"
