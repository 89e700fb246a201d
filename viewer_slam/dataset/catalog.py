"""Known sequences: what a SEQUENCE argument may name, and where its folder is.

A SEQUENCE is, in order of precedence, an existing TUM folder or ROS bag, a synthetic scenario name
(generated once into the cache), or a TUM RGB-D sequence name, either the official archive
name (``rgbd_dataset_freiburg2_360_kidnap``) or its short form (``fr2/360_kidnap``),
which must have been downloaded into the TUM folder (see :func:`tum_cache_dir`) with
``viewslam download`` (the folder, else the ``.bag`` that ``download --bag`` fetched).
"""

import difflib
import os
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from ..cache import cache_dir
from ..errors import InputError

# The TUM RGB-D benchmark's sequences, grouped as on its download page.
_TUM_SEQUENCES = {
    "testing": ("freiburg1_xyz", "freiburg1_rpy", "freiburg2_xyz", "freiburg2_rpy"),
    "handheld": (
        "freiburg1_360",
        "freiburg1_floor",
        "freiburg1_desk",
        "freiburg1_desk2",
        "freiburg1_room",
        "freiburg2_360_hemisphere",
        "freiburg2_360_kidnap",
        "freiburg2_desk",
        "freiburg2_large_no_loop",
        "freiburg2_large_with_loop",
        "freiburg3_long_office_household",
    ),
    "robot": ("freiburg2_pioneer_360", "freiburg2_pioneer_slam", "freiburg2_pioneer_slam2", "freiburg2_pioneer_slam3"),
    "structure_texture": (
        "freiburg3_nostructure_notexture_far",
        "freiburg3_nostructure_notexture_near_withloop",
        "freiburg3_nostructure_texture_far",
        "freiburg3_nostructure_texture_near_withloop",
        "freiburg3_structure_notexture_far",
        "freiburg3_structure_notexture_near",
        "freiburg3_structure_texture_far",
        "freiburg3_structure_texture_near",
    ),
    "dynamic": (
        "freiburg2_desk_with_person",
        "freiburg3_sitting_static",
        "freiburg3_sitting_xyz",
        "freiburg3_sitting_halfsphere",
        "freiburg3_sitting_rpy",
        "freiburg3_walking_static",
        "freiburg3_walking_xyz",
        "freiburg3_walking_halfsphere",
        "freiburg3_walking_rpy",
    ),
    "object_reconstruction": (
        "freiburg1_plant",
        "freiburg1_teddy",
        "freiburg2_coke",
        "freiburg2_dishes",
        "freiburg2_flowerbouquet",
        "freiburg2_flowerbouquet_brownbackground",
        "freiburg2_metallic_sphere",
        "freiburg2_metallic_sphere2",
        "freiburg3_cabinet",
        "freiburg3_large_cabinet",
        "freiburg3_teddy",
    ),
    # Recorded like the others, but TUM keeps their groundtruth for its online evaluation.
    "validation": (
        "freiburg1_xyz_validation",
        "freiburg1_rpy_validation",
        "freiburg1_desk_validation",
        "freiburg1_desk2_validation",
        "freiburg1_360_validation",
        "freiburg1_room_validation",
        "freiburg1_plant_validation",
        "freiburg2_xyz_validation",
        "freiburg2_rpy_validation",
        "freiburg2_360_hemisphere_validation",
        "freiburg2_360_kidnap_validation",
        "freiburg2_desk_validation",
        "freiburg2_desk_with_person_validation",
        "freiburg2_pioneer_360_validation",
        "freiburg3_cabinet_validation",
        "freiburg3_large_cabinet_validation",
        "freiburg3_long_office_household_validation",
        "freiburg3_nostructure_notexture_far_validation",
        "freiburg3_nostructure_notexture_near_withloop_validation",
        "freiburg3_nostructure_texture_far_validation",
        "freiburg3_nostructure_texture_near_withloop_validation",
        "freiburg3_structure_notexture_far_validation",
        "freiburg3_structure_notexture_near_validation",
        "freiburg3_structure_texture_far_validation",
        "freiburg3_structure_texture_near_validation",
        "freiburg3_sitting_static_validation",
        "freiburg3_sitting_xyz_validation",
        "freiburg3_sitting_halfsphere_validation",
        "freiburg3_sitting_rpy_validation",
        "freiburg3_walking_static_validation",
        "freiburg3_walking_xyz_validation",
        "freiburg3_walking_halfsphere_validation",
        "freiburg3_walking_rpy_validation",
    ),
}


@dataclass(frozen=True)
class TumSequenceInfo:
    """One TUM RGB-D sequence: ``name`` is the archive's (and its folder's) name."""

    name: str
    category: str

    @property
    def camera(self) -> str:
        """``freiburg1``, ``freiburg2`` or ``freiburg3``: the sensor, and the server folder."""
        return self.name.split("_")[2]

    @property
    def alias(self) -> str:
        """The short form used in papers: ``fr2/360_kidnap``."""
        return f"fr{self.camera[-1]}/{self.name.split('_', 3)[3]}"

    @property
    def archive(self) -> str:
        """Path of the archive below a mirror's base URL."""
        return f"{self.camera}/{self.name}.tgz"

    @property
    def bag(self) -> str:
        """Path of the sequence's ROS bag below a mirror's base URL."""
        return f"{self.camera}/{self.name}.bag"

    @property
    def groundtruth_public(self) -> bool:
        """Whether the archive holds ``groundtruth.txt`` (all but the validation sequences)."""
        return self.category != "validation"


TUM_SEQUENCES: tuple[TumSequenceInfo, ...] = tuple(
    TumSequenceInfo(f"rgbd_dataset_{suffix}", category)
    for category, suffixes in _TUM_SEQUENCES.items()
    for suffix in suffixes
)

# Every accepted spelling: official name, short name, official name without its prefix.
_BY_FORM = {
    form: info for info in TUM_SEQUENCES for form in (info.name, info.alias, info.name.removeprefix("rgbd_dataset_"))
}


def tum_sequence(name: str) -> TumSequenceInfo | None:
    """The TUM sequence called ``name`` (official, ``fr2/360_kidnap`` or ``freiburg2_360_kidnap``)."""
    return _BY_FORM.get(name)


def known_tum_sequence(name: str) -> TumSequenceInfo:
    """:func:`tum_sequence`, but an unknown name is an InputError that suggests the likely intent."""
    info = tum_sequence(name)
    if info is None:
        raise InputError(f"{name}: unknown TUM sequence; {_did_you_mean(name)}`viewslam sequences` lists them all")
    return info


def _did_you_mean(spec: str, others: Iterable[str] = ()) -> str:
    """``"did you mean A or B? "`` naming up to three TUM short names (or ``others``) that
    ``spec`` looks like a typo of; empty when nothing is close."""
    forms = {form: info.alias for form, info in _BY_FORM.items()} | {name: name for name in others}
    matches = difflib.get_close_matches(spec, forms, n=9, cutoff=0.75)
    guesses = list(dict.fromkeys(forms[match] for match in matches))[:3]
    return f"did you mean {' or '.join(guesses)}? " if guesses else ""


def tum_cache_dir() -> Path:
    """Where ``viewslam download`` puts TUM sequences and where names are looked up.

    ``$VIEWSLAM_DATA`` when set (e.g. a shared data disk), else ``tum`` in the viewslam cache.
    """
    data = os.environ.get("VIEWSLAM_DATA")
    return Path(data).expanduser() if data else cache_dir("tum")


def synthetic_scenarios() -> tuple[str, ...]:
    from .synth.catalog import SCENARIOS

    return tuple(SCENARIOS)


def study_scenarios() -> tuple[str, ...]:
    """The scenarios of the study's seven situations, without the variants."""
    from .synth.catalog import STUDY_SCENARIOS

    return tuple(STUDY_SCENARIOS)


def resolve_sequence(
    spec: str,
    *,
    frames: int | None = None,
    resolution: tuple[int, int] = (640, 480),
    seed: int = 0,
    first: int | None = None,
    progress: bool = False,
) -> Path:
    """The folder of the TUM sequence ``spec`` names (see the module docstring for the forms).

    ``frames``, ``resolution`` and ``seed`` size a synthetic scenario, ``first`` the frames of
    it that will be read (only those are rendered), ``progress`` shows the rendering on
    stderr; they do not apply to recorded sequences.
    """
    path = Path(spec).expanduser()
    if path.is_dir() or (path.suffix == ".bag" and path.is_file()):
        return path
    scenarios = synthetic_scenarios()
    if spec in scenarios:
        from .synth import cached_scenario

        return cached_scenario(spec, frames=frames, resolution=resolution, seed=seed, first=first, progress=progress)
    info = tum_sequence(spec)
    if info is not None:
        folder, bag = tum_cache_dir() / info.name, tum_cache_dir() / f"{info.name}.bag"
        if folder.is_dir():
            return folder
        if bag.is_file():
            return bag
        raise InputError(f"{spec}: TUM sequence not downloaded; run `viewslam download {info.alias}`")
    raise InputError(
        f"{spec}: not a folder, synthetic scenario or TUM sequence; {_did_you_mean(spec, scenarios)}"
        f"scenarios: {', '.join(scenarios)}; `viewslam sequences` lists the {len(TUM_SEQUENCES)} TUM sequences"
    )
