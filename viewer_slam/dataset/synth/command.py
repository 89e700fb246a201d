"""``viewslam synth`` as a library function: a synthetic scenario rendered as a TUM RGB-D folder."""

from dataclasses import dataclass
from pathlib import Path

from .generate import generate_scenario, read_info


@dataclass(frozen=True)
class SynthResult:
    """The folder written and what is in it: its frame count, scenario, image size and the
    scenario's notes (what it tests)."""

    folder: Path
    frames: int
    scenario: str
    resolution: tuple[int, int]
    notes: str


def synth(
    scenario: str,
    out: Path,
    *,
    frames: int | None = None,
    resolution: tuple[int, int] = (640, 480),
    seed: int = 0,
    camera: str = "fr3",
    force: bool = False,
    quiet: bool = True,
) -> SynthResult:
    """Render ``scenario`` (a name of the scenario catalogue) into the folder ``out`` (rgb/, depth/,
    rgb.txt, depth.txt, groundtruth.txt, camera.json), ``frames`` long (default: the scenario's own
    length) at ``resolution`` with TUM's ``camera`` intrinsics (fr1, fr2 or fr3, scaled); ``seed``
    seeds the scene, the motion's tremor and the sensor noise, so the same arguments give the same
    bytes. An existing non-empty ``out`` is replaced only with ``force``; ``quiet`` hides the progress.
    """
    folder = generate_scenario(
        scenario, out, frames=frames, resolution=resolution, seed=seed, camera=camera, force=force, progress=not quiet
    )
    info = read_info(folder)
    return SynthResult(
        Path(folder),
        int(info["frames"]),
        str(info["scenario"]),
        (int(info["resolution"][0]), int(info["resolution"][1])),
        str(info["notes"]),
    )
