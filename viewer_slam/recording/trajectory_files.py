"""A Rerun recording of trajectory files alone: a groundtruth and runs aligned onto it (the study's).

Runs that come without images (the study's published ones) show what a trajectory file can:
the groundtruth, each run aligned as its ATE saw it with its poses coloured by their error,
the per-pose ATE on the dataset's time, and the intervals each run was lost.
"""

from pathlib import Path

import numpy as np

from .. import palette
from ..evaluation import evaluate
from ..geometry.trajectory import read_tum


def record_trajectory_files(target: Path, name: str, groundtruth_file: Path, runs: dict[str, Path]) -> None:
    """Write ``target`` (.rrd), the recording ``name``: ``world/groundtruth``, ``world/<run>`` and
    ``metrics/<run>/ate``."""
    import rerun as rr

    groundtruth = read_tum(groundtruth_file)
    stream = rr.RecordingStream(name)
    partial = target.with_name(f".{target.name}.part")
    stream.save(str(partial))
    stream.log("world/groundtruth", rr.LineStrips3D([groundtruth.positions], colors=[(160, 160, 160)]), static=True)
    for position, (name, path) in enumerate(runs.items()):
        estimate = read_tum(path)
        evaluation = evaluate(groundtruth, estimate, rpe_mode="tum")
        colour = palette.run_colour(name, position).rgb
        aligned = evaluation.aligned_positions(estimate)
        if aligned is None:
            continue
        errors = np.full(len(estimate), np.nan)
        errors[evaluation.pairs[1]] = evaluation.ate.errors
        stream.log(f"world/{name}/trajectory", rr.LineStrips3D([aligned], colors=[colour]), static=True)
        worst = np.nanmax(errors) or 1.0
        shades = [(255, int(255 * (1 - min(e / worst, 1))), 0) if np.isfinite(e) else (90, 90, 90) for e in errors]
        stream.log(f"world/{name}/poses", rr.Points3D(aligned, colors=shades, radii=0.01), static=True)
        stream.log(f"metrics/{name}/ate", rr.SeriesLines(colors=[colour], names=[f"{name} ATE [m]"]), static=True)
        for stamp, error in zip(estimate.timestamps[evaluation.pairs[1]], evaluation.ate.errors):
            stream.set_time("time", timestamp=float(stamp))
            stream.log(f"metrics/{name}/ate", rr.Scalars(float(error)))
        for start, end in evaluation.coverage.lost_intervals:
            stream.set_time("time", timestamp=float(start))
            stream.log(f"metrics/{name}/events", rr.TextLog(f"{name} lost from here until {end - start:.1f} s later",
                                                            level="WARN"))
    stream.flush()
    del stream
    partial.replace(target)
