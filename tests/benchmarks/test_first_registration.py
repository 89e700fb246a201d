"""benchmarks.first_registration: one registration of our odometry beside the original's."""

import pytest

from benchmarks import first_registration
from benchmarks.figures import TUM
from benchmarks.reference import REFERENCE
from viewer_slam.errors import InputError

RUN = "rgbd_dataset_freiburg1_rpy_200-perframe"


def test_a_missing_reference_run_is_refused(tmp_path):
    with pytest.raises(InputError, match=f"{tmp_path / RUN}: no such reference run"):
        first_registration.main(["--reference", str(tmp_path)])


def test_frame_zero_is_no_registration():
    with pytest.raises(SystemExit) as exit_:
        first_registration.main(["--frame", "0"])
    assert exit_.value.code == 2


@pytest.mark.skipif(
    not (REFERENCE / RUN).is_dir() or not (TUM / "rgbd_dataset_freiburg1_rpy_200").is_dir(),
    reason="the original's runs and the TUM excerpt are not beside the repository",
)
def test_the_first_registration_beside_the_originals(capsys):
    assert first_registration.main([]) == 0
    printed = capsys.readouterr().out
    assert printed.startswith(f"{RUN}, frame 1 ")
    assert "the original: 814 features, 155 inliers" in printed  # read from its nodes.csv
    assert "under our pose" in printed and "any pose near the original's" in printed
