"""Known sequences: what a SEQUENCE argument may name, and where its folder is.

A SEQUENCE is, in order of precedence, an existing TUM folder, a synthetic scenario name
(generated once into the cache), or a TUM RGB-D sequence name, either the official archive
name (``rgbd_dataset_freiburg2_360_kidnap``) or its short form (``fr2/360_kidnap``),
which must have been downloaded into the cache with ``viewslam download``.
"""

from dataclasses import dataclass
from pathlib import Path

from ..cache import cache_dir
from ..errors import InputError

# The TUM RGB-D benchmark's sequences, grouped as on its download page.
_TUM_SEQUENCES = {
    "testing": ("freiburg1_xyz", "freiburg1_rpy", "freiburg2_xyz", "freiburg2_rpy"),
    "handheld": ("freiburg1_360", "freiburg1_floor", "freiburg1_desk", "freiburg1_desk2", "freiburg1_room",
                 "freiburg2_360_hemisphere", "freiburg2_360_kidnap", "freiburg2_desk", "freiburg2_large_no_loop",
                 "freiburg2_large_with_loop", "freiburg3_long_office_household"),
    "robot": ("freiburg2_pioneer_360", "freiburg2_pioneer_slam", "freiburg2_pioneer_slam2", "freiburg2_pioneer_slam3"),
    "structure_texture": ("freiburg3_nostructure_notexture_far", "freiburg3_nostructure_notexture_near_withloop",
                          "freiburg3_nostructure_texture_far", "freiburg3_nostructure_texture_near_withloop",
                          "freiburg3_structure_notexture_far", "freiburg3_structure_notexture_near",
                          "freiburg3_structure_texture_far", "freiburg3_structure_texture_near"),
    "dynamic": ("freiburg2_desk_with_person", "freiburg3_sitting_static", "freiburg3_sitting_xyz",
                "freiburg3_sitting_halfsphere", "freiburg3_sitting_rpy", "freiburg3_walking_static",
                "freiburg3_walking_xyz", "freiburg3_walking_halfsphere", "freiburg3_walking_rpy"),
    "object_reconstruction": ("freiburg1_plant", "freiburg1_teddy", "freiburg2_coke", "freiburg2_dishes",
                              "freiburg2_flowerbouquet", "freiburg2_flowerbouquet_brownbackground",
                              "freiburg2_metallic_sphere", "freiburg2_metallic_sphere2", "freiburg3_cabinet",
                              "freiburg3_large_cabinet", "freiburg3_teddy"),
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


TUM_SEQUENCES: tuple[TumSequenceInfo, ...] = tuple(
    TumSequenceInfo(f"rgbd_dataset_{suffix}", category)
    for category, suffixes in _TUM_SEQUENCES.items() for suffix in suffixes
)

_BY_NAME = {info.name: info for info in TUM_SEQUENCES}
_BY_ALIAS = {info.alias: info for info in TUM_SEQUENCES}
_BY_SUFFIX = {info.name.removeprefix("rgbd_dataset_"): info for info in TUM_SEQUENCES}


def tum_sequence(name: str) -> TumSequenceInfo | None:
    """The TUM sequence called ``name`` (official, ``fr2/360_kidnap`` or ``freiburg2_360_kidnap``)."""
    return _BY_NAME.get(name) or _BY_ALIAS.get(name) or _BY_SUFFIX.get(name)


def tum_cache_dir() -> Path:
    """Where ``viewslam download`` puts TUM sequences by default."""
    return cache_dir("tum")


def synthetic_scenarios() -> tuple[str, ...]:
    from .synth import SCENARIOS

    return tuple(SCENARIOS)


def resolve_sequence(spec: str, *, frames: int | None = None, resolution: tuple[int, int] = (640, 480),
                     seed: int = 0) -> Path:
    """The folder of the TUM sequence ``spec`` names (see the module docstring for the forms).

    ``frames``, ``resolution`` and ``seed`` size a synthetic scenario; they do not apply to
    recorded sequences.
    """
    path = Path(spec).expanduser()
    if path.is_dir():
        return path
    scenarios = synthetic_scenarios()
    if spec in scenarios:
        from .synth import cached_scenario

        return cached_scenario(spec, frames=frames, resolution=resolution, seed=seed)
    info = tum_sequence(spec)
    if info is not None:
        folder = tum_cache_dir() / info.name
        if folder.is_dir():
            return folder
        raise InputError(f"{spec}: TUM sequence not downloaded; run `viewslam download {info.alias}`")
    raise InputError(
        f"{spec}: not a folder, synthetic scenario or TUM sequence; scenarios: {', '.join(scenarios)}; "
        f"TUM sequences: {', '.join(info.alias for info in TUM_SEQUENCES)} (see `viewslam sequences`)"
    )
