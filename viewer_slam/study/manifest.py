"""What the seed study published, where, and the SHA-256 of every file of it that viewslam reads.

The author of "Benchmarking and Comparing Popular Visual SLAM Algorithms" (Kasar 2018)
published the trajectories his paper scored, the result logs of TUM's evaluation scripts,
and the scripts that drew the paper's four charts, in the GitHub repository
ameykasar/benchmarking-slam (MIT). Everything is read at one pinned commit, so the
figures replayed here are those of the paper's own runs, and each file is checked against
its hash before it is used: a changed file is not the study's file.
"""

from dataclasses import dataclass

REPOSITORY = "ameykasar/benchmarking-slam"
COMMIT = "ca066ba97e83b504a44d2c04eb6e0de39c02b447"
BASE_URL = f"https://raw.githubusercontent.com/{REPOSITORY}/{COMMIT}"


@dataclass(frozen=True)
class StudySequence:
    """One of the study's seven sequences: the author's folder, TUM's name, and its chart label."""

    folder: str
    name: str
    label: str  # the x tick of the paper's charts, newlines removed

    @property
    def alias(self) -> str:
        """TUM's short form, ``fr2/360_kidnap``."""
        camera, _, rest = self.name.removeprefix("rgbd_dataset_freiburg").partition("_")
        return f"fr{camera}/{rest}"


@dataclass(frozen=True)
class StudySystem:
    """One of the two systems: its name in results, the author's subfolder, the run and its log."""

    name: str
    title: str
    subfolder: str
    poses: str
    chart_variable: str  # the list of the chart scripts that holds its bars


SEQUENCES = (
    StudySequence("freiburg2_desk_with_person", "rgbd_dataset_freiburg2_desk_with_person", "fr2/desk with person"),
    StudySequence("freiburg2_360_pioneer_slam", "rgbd_dataset_freiburg2_pioneer_360", "fr2/pioneer360 robot slam"),
    StudySequence("freiburg2_360_kidnap", "rgbd_dataset_freiburg2_360_kidnap", "fr2/360 kidnap"),
    StudySequence(
        "freiburg3_long_office_household", "rgbd_dataset_freiburg3_long_office_household", "fr3/long office household"
    ),
    StudySequence(
        "freiburg3_no_structure_no_texture",
        "rgbd_dataset_freiburg3_nostructure_notexture_near_withloop",
        "fr3/no struct no texture",
    ),
    StudySequence(
        "freiburg3_no_structure_texture",
        "rgbd_dataset_freiburg3_nostructure_texture_near_withloop",
        "fr3/no struct texture",
    ),
    StudySequence("freiburg3_sitting_static", "rgbd_dataset_freiburg3_sitting_static", "fr3/sitting static"),
)
SYSTEMS = (
    StudySystem("rgbdslam_v2", "RGB-D SLAM v2", "rgbd", "rgbd_poses.txt", "rgbd"),
    StudySystem("rtabmap", "RTAB-Map", "rtab", "rtabmap_poses.txt", "rtab"),
)
# chart script -> the figure its bars show
CHARTS = {
    "scripts/ate.py": "ate_rmse",
    "scripts/rpetrans.py": "rpe_trans_rmse",
    "scripts/rperot.py": "rpe_rot_rmse_deg",
    "scripts/time.py": "time_s",
}


def groundtruth_path(sequence: StudySequence) -> str:
    """The groundtruth beside the RGB-D SLAM run (the same TUM file lies beside both runs)."""
    return f"{sequence.folder}/rgbd/groundtruth.txt"


def poses_path(sequence: StudySequence, system: StudySystem) -> str:
    return f"{sequence.folder}/{system.subfolder}/{system.poses}"


def log_path(sequence: StudySequence, system: StudySystem) -> str:
    """The result log the author wrote beside each run (one of them named without the underscore)."""
    if system.subfolder == "rgbd":
        name = "rgbdresult.txt" if sequence.folder == "freiburg3_sitting_static" else "rgbd_result.txt"
    else:
        name = "rtabmap_result.txt"
    return f"{sequence.folder}/{system.subfolder}/{name}"


def sequence_files(sequence: StudySequence) -> list[str]:
    return [groundtruth_path(sequence)] + [
        path for system in SYSTEMS for path in (poses_path(sequence, system), log_path(sequence, system))
    ]


# SHA-256 of the files at COMMIT. The three sequences that were not at hand when the manifest
# was written have no hash yet (None): they are fetched, used, and reported as unverified.
SHA256 = {
    "freiburg2_360_kidnap/rgbd/groundtruth.txt": "a31679d9a5a2e8f0f00174636fb6490bc62ec106563d1ace1a0852a7fcc35cee",
    "freiburg2_360_kidnap/rgbd/rgbd_poses.txt": "aa24bfb51594de104f8fad200d0703ee4337cb69e70cf9eb832c565f74d4b833",
    "freiburg2_360_kidnap/rgbd/rgbd_result.txt": "6c1d7e9d402f62665018ea3bf5c86ebc04db4720d71eec95c4e2888e5b5d5a79",
    "freiburg2_360_kidnap/rtab/rtabmap_poses.txt": "ad1a8b0ef3937c149894eae92fd857452708f8365c3ee06ef4eff5c00f1763f7",
    "freiburg2_360_kidnap/rtab/rtabmap_result.txt": "dca62dfb5bbe1dda1cf05fe8dfb8954c27973f040d9740234ab1bced046bd876",
    "freiburg3_long_office_household/rgbd/groundtruth.txt": "e255d5d9c5bab915132c7ac5ec4e23f9f1efe98f765b0c9b26ac74e40b02533f",
    "freiburg3_long_office_household/rgbd/rgbd_poses.txt": "13ef6c01d9b7c31d523a3e7c4836fa53d3b0959ae7af8fec0134f6f4d15f4a6d",
    "freiburg3_long_office_household/rgbd/rgbd_result.txt": "1f2e30ce27e21e0b8a8c28bb1084daf51fb8429cf12defd79e0f0af8f9aca29e",
    "freiburg3_long_office_household/rtab/rtabmap_poses.txt": "41ce730db2d57778eda87a0e916028e4c4c5102bfa050e1f74554125f83291f7",
    "freiburg3_long_office_household/rtab/rtabmap_result.txt": "d20877ce181fed42c45c1ec81141bc06b6b80ec132c1c43b97906fe3276cc145",
    "freiburg3_no_structure_no_texture/rgbd/groundtruth.txt": "f463c39800a81c96a7f9c08601308d6c5519c4de701f55acdf51a1a93a20221a",
    "freiburg3_no_structure_no_texture/rgbd/rgbd_poses.txt": "d8e2ee64ea2882c6098657617467c1145be79f4c7078dc0fc39bc266c4537e75",
    "freiburg3_no_structure_no_texture/rgbd/rgbd_result.txt": "5a13417b74be42ed1544331fb6a358f58c9d443b8aff03899d61717afaf91a66",
    "freiburg3_no_structure_no_texture/rtab/rtabmap_poses.txt": "a95283c11cc98aec3521040a8a14cfc282b2829173c9f2a27055b2e6186b6c5d",
    "freiburg3_no_structure_no_texture/rtab/rtabmap_result.txt": "bd752802c20fc6c26cc9c735602b4bc6a74c0e3c6a2dd211bcbe157d586c7276",
    "freiburg3_sitting_static/rgbd/groundtruth.txt": "13b03e2568833bb0a5ca901df587a882549b155682fff722eb94d726a3a4451c",
    "freiburg3_sitting_static/rgbd/rgbd_poses.txt": "e4f5158e0848e2b702308e4c264569920785ae75058b49d8663fbb9acc421a55",
    "freiburg3_sitting_static/rgbd/rgbdresult.txt": "9381c31348085b734b17c82699787f11d7ce49a34a5e189f4873b75f471ee46c",
    "freiburg3_sitting_static/rtab/rtabmap_poses.txt": "27a66feaaf3920d0647a593a3897df8e60560f42388033bfc960746b26cb07c2",
    "freiburg3_sitting_static/rtab/rtabmap_result.txt": "58027a705e63c18765a3b6c7773fb18ed014193fba914f83ddaf42cf08eca304",
    "scripts/ate.py": "f38d292aea2855a2bd2f9e89d80208e69f25e84e16951d266f9c952ba81a9f24",
    "scripts/rpetrans.py": "07b97ba99b962fdbc9a45861960f03765a5d86a41333950affea841a14945901",
    "scripts/rperot.py": "bc0cb336da5a61919123429e226a4aff57e836b1d811bb59a854ae8dbec8cea2",
    "scripts/time.py": "3673c1ddc3fc676b98285ded8ace8014f59764e152b1058e0d8b9ef67fc57525",
}


def known_sequence(name: str) -> StudySequence | None:
    """The study sequence called ``name``: TUM's name, its short form, or the author's folder."""
    for sequence in SEQUENCES:
        if name in (sequence.name, sequence.alias, sequence.folder, sequence.name.removeprefix("rgbd_dataset_")):
            return sequence
    return None
