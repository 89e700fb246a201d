"""Which synthetic scenarios exist and what each tests: the list every command can read
without loading the renderer (or OpenCV, which its textures use)."""

from dataclasses import dataclass


@dataclass(frozen=True)
class ScenarioInfo:
    name: str
    mirrors: str
    tests: str
    default_frames: int
    in_study: bool = True  # one of the seven situations of the study (the benchmark's default)


# The longest scenario rendered: the frames' stamps, poses and plan are allocated up front.
MAX_FRAMES = 100_000

SCENARIO_INFO = {
    info.name: info
    for info in (
        ScenarioInfo(
            "desk_with_person",
            "fr2/desk_with_person",
            "dynamic objects: a person moving and shifting an object in an otherwise static office",
            600,
        ),
        ScenarioInfo(
            "pioneer_360",
            "fr2/pioneer_360",
            "robot motion (planar, full turn) in a large hall with walls beyond depth range and feature-poor boxes",
            900,
        ),
        ScenarioInfo(
            "360_kidnap",
            "fr2/360_kidnap",
            "recovery after the sensor is covered and moved (kidnapping), and loop closure across the gap",
            600,
        ),
        ScenarioInfo(
            "360_kidnap_norevisit",
            "fr2/360_kidnap (variant)",
            "the same kidnapping, but no view mapped before a covering is seen again: nothing to re-localise on",
            600,
            in_study=False,
        ),
        ScenarioInfo(
            "long_office_household",
            "fr3/long_office_household",
            "a long textured round ending over the start: drift and one large loop closure",
            1200,
        ),
        ScenarioInfo(
            "nostructure_notexture_near_withloop",
            "fr3/nostructure_notexture_near_withloop",
            "a faint, flat wooden plane at ~1 m with a featureless stretch: feature trackers lose track",
            900,
        ),
        ScenarioInfo(
            "nostructure_texture_near_withloop",
            "fr3/nostructure_texture_near_withloop",
            "the same motion over posters: flat but richly textured, a loop closure back to the start",
            900,
        ),
        ScenarioInfo(
            "sitting_static",
            "fr3/sitting_static",
            "an almost static camera watching two people gesture: the static-world assumption under small motion",
            450,
        ),
    )
}
SCENARIOS = tuple(SCENARIO_INFO)
STUDY_SCENARIOS = tuple(name for name, info in SCENARIO_INFO.items() if info.in_study)
