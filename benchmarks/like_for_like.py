"""viewslam's rtabmap against the real RTAB-Map 0.23.8, like for like and frame by frame.

    python -m benchmarks.like_for_like                      # every reference run found
    python -m benchmarks.like_for_like rgbd_dataset_freiburg1_rpy_200-perframe
    python -m benchmarks.like_for_like 360_kidnap-default --synthetic DIR   # DIR: the rendered scenes
    python -m benchmarks.like_for_like ... --param Vis/MinInliers=20 --out DIR

The reference (``../shared/data/reference/rtabmap-0.23.8``, ``--reference``) holds the
original's runs, one folder per sequence and mode: ``<sequence>-perframe`` (a node every
frame: Rtabmap/DetectionRate 0, RGBD/LinearUpdate 0, RGBD/AngularUpdate 0) and
``<sequence>-default``. Each is replayed in the original's configuration:

- the same frames (the TUM folder of the same name under ``--tum``, or the synthetic scene
  rendered under ``--synthetic``, checked against the reference's SHA-256 list);
- the same camera: the intrinsics the original used, without lens distortion (the dataset
  tool reads no distortion coefficients), through a view of the folder with its own
  camera.json;
- the same mode, and OdomF2M/BundleAdjustment 0 (that build has no g2o); ``--config`` and
  ``--param`` as ``viewslam record`` takes them, ``--param`` on top of that configuration.

The run is written as ``viewslam record`` writes one (report, trajectory files), with the
original's optimised graph (``poses_tum.txt``) and its odometry (``db_poses_odom_tum.txt``)
replayed beside it as estimates (``--estimate``), so ``viewslam diff`` compares them; the
command to do so is printed. Then, per frame: odometry inliers, features, local map size,
key frame decisions, loop closure hypotheses accepted and rejected, proximity links,
where the two first diverge and where most.
"""

import argparse
import json
import tempfile
from functools import partial
from pathlib import Path

import viewer_slam.code_paths  # noqa: F401  (before NumPy loads: holds it to one code path)

import numpy as np

from viewer_slam.atomic import StagedFiles
from viewer_slam.comparison.compare import compare_reports
from viewer_slam.comparison.output import print_comparison
from viewer_slam.dataset.sources import open_source
from viewer_slam.errors import InputError
from viewer_slam.evaluation import evaluate
from viewer_slam.evaluation.rpe import relative_errors
from viewer_slam.geometry.association import associate
from viewer_slam.geometry.trajectory import Trajectory, write_tum
from viewer_slam.pipelines.events import Event, FrameTracked, GraphEdge, KeyframeAdded, TrackingRecovered
from viewer_slam.pipelines.params import parse_assignments
from viewer_slam.runs.run_report import build_report, write_report
from viewer_slam.runs.service import EstimateSpec

from . import lab
from .figures import TUM
from .reference import (
    REFERENCE,
    REFERENCE_NAME,
    ReferenceRun,
    camera_view,
    frame_rows,
    frames_folder,
    number,
    read_links,
    read_nodes,
    reference_camera,
    reference_runs,
    same_frames,
)

FRAME_STAMP_TOLERANCE = 0.005  # s: a pose belongs to the frame taken within this (frames 33 ms apart)
# A count differs when it is off by more than this share of the reference's (and by more than 2).
COUNT_TOLERANCE = 0.2
# The original's optimised graph and its odometry, replayed as estimates, by their run names.
REFERENCE_FILES = {REFERENCE_NAME: "poses_tum.txt", f"{REFERENCE_NAME}-odometry": "db_poses_odom_tum.txt"}


# -- the reference's per-frame internals -----------------------------------------------------


def reference_series(run: ReferenceRun, stamps: np.ndarray) -> dict[str, np.ndarray]:
    """Per processed frame (NaN where the original has no node): its statistics."""
    nodes = read_nodes(run)
    frame_of_stamp = {round(s, 4): i for i, s in enumerate(stamps)}
    frame_of_node = {}
    series = {
        key: np.full(len(stamps), np.nan)
        for key in ("inliers", "features", "local_map", "key_frame", "loop_accepted", "loop_rejected", "proximity")
    }
    for node in nodes:
        frame = frame_of_stamp.get(round(float(node["stamp"]), 4))
        if frame is None:
            continue
        frame_of_node[int(node["node_id"])] = frame
        series["inliers"][frame] = number(node["odom_inliers"])
        series["features"][frame] = number(node["odom_features"])
        series["local_map"][frame] = number(node["odom_local_map_size"])
        series["key_frame"][frame] = number(node["odom_keyframe_added"])
        for key in ("loop_accepted", "loop_rejected", "proximity"):
            series[key][frame] = 0
        series["loop_rejected"][frame] = number(node["loop_rejected"])
    for link in read_links(run):
        kind = {"global_loop": "loop_accepted", "local_space": "proximity"}.get(link["type_name"])
        newer = max(int(link["from_id"]), int(link["to_id"]))
        if kind and newer in frame_of_node:
            series[kind][frame_of_node[newer]] += 1
    for row in frame_rows(run):  # synthetic runs: odometry of every frame, nodes or not
        frame = frame_of_stamp.get(round(float(row["stamp"]), 4))
        if frame is not None:
            series["inliers"][frame] = number(row["inliers"])
            series["features"][frame] = number(row["features"])
    return series


def our_series(events, count: int) -> dict[str, np.ndarray]:
    series = {
        key: np.full(count, np.nan)
        for key in (
            "inliers",
            "features",
            "local_map",
            "key_frame",
            "loop_accepted",
            "loop_rejected",
            "proximity",
            "node",
        )
    }
    for event in events:
        if isinstance(event, FrameTracked) and event.frame_index < count:
            i = event.frame_index
            series["inliers"][i] = event.inliers
            series["features"][i] = event.features
            series["local_map"][i] = event.metrics.get("local_map", np.nan)
            series["key_frame"][i] = event.metrics.get("key_frame", np.nan)
            for key in ("loop_accepted", "loop_rejected", "proximity", "node"):
                series[key][i] = 0
    for event in events:
        if isinstance(event, KeyframeAdded):
            series["node"][event.frame_index] = 1
        elif isinstance(event, GraphEdge) and event.frame_index < count:
            if event.detection == "appearance":
                series["loop_accepted" if event.accepted else "loop_rejected"][event.frame_index] += 1
            elif event.detection == "proximity" and event.accepted:
                series["proximity"][event.frame_index] += 1
    return series


def divergence(name: str, ours: np.ndarray, reference: np.ndarray) -> str:
    """Where a per-frame series first and most departs from the reference's."""
    both = ~np.isnan(ours) & ~np.isnan(reference)
    if not both.any():
        return f"| {name} | – | – | – | – | – |"
    frames = np.flatnonzero(both)
    difference = ours[both] - reference[both]
    binary = name in ("key_frame", "loop_accepted", "loop_rejected", "proximity")
    off = (
        (difference != 0) if binary else (np.abs(difference) > np.maximum(2, COUNT_TOLERANCE * np.abs(reference[both])))
    )
    first = f"{frames[np.argmax(off)]}" if off.any() else "none"
    most = frames[np.argmax(np.abs(difference))]
    agree = f"{1 - off.mean():.0%}"
    return (
        f"| {name} | {np.nansum(ours[both]):.0f} / {np.nansum(reference[both]):.0f} "
        f"| {np.median(ours[both]):.0f} / {np.median(reference[both]):.0f} | {agree} | {first} "
        f"| {most} ({ours[most]:.0f} vs {reference[most]:.0f}) |"
    )


def frame_to_frame(trajectory, sequence) -> str:
    """Mean / median translation error (cm) of the motion between poses of consecutive frames
    (RPE over one frame; a pair across frames without a pose is not one): how closely one
    registration follows the next, which the ATE of a drifting odometry hides."""
    if trajectory is None or len(trajectory) < 2:
        return "–"
    frame = np.searchsorted(sequence.timestamps, trajectory.timestamps - FRAME_STAMP_TOLERANCE)
    consecutive = np.flatnonzero(np.diff(frame) == 1)
    truth, covered = sequence.groundtruth_at(trajectory.timestamps)
    consecutive = consecutive[covered[consecutive] & covered[consecutive + 1]]
    if len(consecutive) == 0:
        return "–"
    errors = relative_errors(truth, trajectory.poses, consecutive, consecutive + 1)[0] * 100
    return f"{errors.mean():.2f} / {np.median(errors):.2f} ({len(errors)} pairs)"


def pose_divergence(our_trajectory, reference_trajectory, sequence, label: str) -> str:
    """Per-frame ATE (each aligned to the groundtruth on its own): first frame where ours is worse
    by over 2 cm, and where most."""
    if our_trajectory is None or reference_trajectory is None or len(reference_trajectory) < 3:
        return f"{label}: –"
    if sequence.groundtruth is None:
        return f"{label}: no groundtruth"
    ours = evaluate(sequence.groundtruth, our_trajectory).ate
    theirs = evaluate(sequence.groundtruth, reference_trajectory).ate
    if ours is None or theirs is None:
        return f"{label}: –"
    ours_at = dict(zip(np.round(ours.timestamps, 4), ours.errors))
    pairs = [(t, ours_at[round(t, 4)], e) for t, e in zip(theirs.timestamps, theirs.errors) if round(t, 4) in ours_at]
    if not pairs:
        return f"{label}: no common stamps"
    stamps = sequence.timestamps
    frame = {round(s, 4): i for i, s in enumerate(stamps)}
    worse = [(frame.get(round(t, 4)), a - b) for t, a, b in pairs]
    first = next((f for f, d in worse if d > 0.02), None)
    most = max(worse, key=lambda item: abs(item[1]))
    return (
        f"{label}: ATE {ours.stats()['rmse'] * 100:.2f} cm (ours) vs {theirs.stats()['rmse'] * 100:.2f} cm "
        f"({REFERENCE_NAME}) over {len(pairs)} common frames; ours first worse by > 2 cm at frame {first}, "
        f"most apart at frame {most[0]} ({most[1] * 100:+.1f} cm)"
    )


# -- one comparison ----------------------------------------------------------------------------


def compare(run: ReferenceRun, frames: Path, out: Path, options: argparse.Namespace) -> dict:
    listed, equal, differing_images = same_frames(run, frames)
    spec = lab.pipeline_spec("rtabmap", options, preset=run.overrides)
    with tempfile.TemporaryDirectory() as views:
        sequence = open_source(camera_view(frames, reference_camera(open_source(frames).camera), Path(views)))
        events: list[Event] = []
        scored = {"rtabmap": lab.run(sequence, spec, "rtabmap", sinks=[events.append])}
        scored.update(
            {name: lab.run(sequence, EstimateSpec(run.folder / file), name) for name, file in REFERENCE_FILES.items()}
        )
        ours = scored["rtabmap"].run
        replays = {name: scored[name].run for name in REFERENCE_FILES}
        blocks = {name: result.report for name, result in scored.items()}
        report_path = out / f"{run.name}.json"
        report = build_report(sequence, blocks, interrupted=False)
        report["sequence"]["path"] = str(frames)
        report["like_for_like"] = {
            "reference": str(run.folder),
            "mode": run.mode,
            "overrides": {**run.overrides, **parse_assignments(options.param)},
            "camera": sequence.camera.to_json(),
            "frames_checked": {"listed": listed, "equal": equal, "images_differing": differing_images},
        }
        out.mkdir(parents=True, exist_ok=True)
        with StagedFiles() as staged:
            staged.write(report_path, lambda path: write_report(path, report))
            trajectories: dict[str, Trajectory | None] = {
                name: result.run.trajectory for name, result in scored.items()
            }
            trajectories["rtabmap-odometry"] = ours.odometry
            for name, trajectory in trajectories.items():
                if trajectory is not None:
                    staged.write(out / f"{run.name}.{name}.txt", partial(write_tum, trajectory=trajectory))
            staged.commit()
        stamps = np.asarray(sequence.timestamps)
        ref_series = reference_series(run, stamps)
        our = our_series(events, len(stamps))
        summary = summarise(
            run,
            blocks,
            ours,
            our,
            ref_series,
            sequence,
            replays,
            report_path,
            (listed, equal, differing_images),
            events,
        )
    return summary


def first_loss(rows: list[dict]) -> int | None:
    """The first frame where the original's odometry is lost, or None."""
    return next((int(row["frame"]) for row in rows if row["odom_lost"] == "1"), None)


def errors_laid_on_first_stretch(odometry, sequence, before: int) -> dict[int, float]:
    """Position error (m) per frame of an odometry trajectory laid onto the groundtruth by its
    poses before frame ``before``: the rotation that best maps their orientations onto the
    groundtruth's, then the mean offset of the positions. A camera turning in place spans
    centimetres, too little for a fit of positions alone (the ATE's) to fix the rotation, and
    a resumption metres from there would be judged by that guess."""
    stamps = np.asarray(sequence.timestamps)
    in_frames, at = associate(odometry.timestamps, stamps, max_difference=FRAME_STAMP_TOLERANCE)
    with_truth, truth = associate(odometry.timestamps[in_frames], sequence.groundtruth.timestamps)
    frame, estimate = at[with_truth], odometry.poses[in_frames][with_truth]
    groundtruth = sequence.groundtruth.poses[truth]
    early = frame < before
    if early.sum() < 2:
        return {}
    u, _, vt = np.linalg.svd(np.einsum("nij,nkj->ik", groundtruth[early, :3, :3], estimate[early, :3, :3]))
    rotation = u @ np.diag([1, 1, np.linalg.det(u @ vt)]) @ vt
    offset = (groundtruth[early, :3, 3] - estimate[early, :3, 3] @ rotation.T).mean(axis=0)
    errors = np.linalg.norm(estimate[:, :3, 3] @ rotation.T + offset - groundtruth[:, :3, 3], axis=1)
    return dict(zip(frame.tolist(), errors.tolist()))


def resumption_errors(odometry, sequence, before: int, frames: list[int]) -> str:
    """The error (cm) over the poses before frame ``before`` (min–max, median), then at each of
    ``frames`` (see :func:`errors_laid_on_first_stretch`)."""
    error_at = errors_laid_on_first_stretch(odometry, sequence, before)
    first = [100 * error for frame, error in error_at.items() if frame < before]
    if not first:
        return "–"
    at = " / ".join(f"{100 * error_at[f]:.1f}" if f in error_at else "–" for f in frames) or "–"
    return f"before it {min(first):.1f}–{max(first):.1f} (median {np.median(first):.1f}), at each resumption {at}"


def resumptions(rows: list[dict]) -> list[tuple[int, int]]:
    """(frame, inliers) where the original's odometry registers again after lost frames."""
    return [
        (int(row["frame"]), int(float(row["inliers"])))
        for before, row in zip(rows, rows[1:])
        if before["odom_lost"] == "1" and row["odom_lost"] == "0"
    ]


def summarise(run, blocks, ours, our, ref, sequence, replays, report_path, checked, events) -> dict:
    reference_summary = json.loads((run.folder / "summary.json").read_text())
    links = reference_summary.get("db", {}).get("links_by_type", {})
    ours_block, ref_block = blocks["rtabmap"], blocks[REFERENCE_NAME]
    listed, equal, differing = checked
    cm = lambda stats: f"{stats['rmse'] * 100:.2f}" if stats else "–"  # noqa: E731
    detections = ours_block["edges_by_detection"]
    print(f"\n## {run.name} ({len(sequence)} frames, {run.mode}; OdomF2M/BundleAdjustment 0, no lens distortion)\n")
    if listed:
        print(
            f"frames: {equal} of {listed} files byte-equal to the reference's render"
            + (f" ({differing} images differ: the same scenario and seed, another render)" if differing else "")
        )
    print("\n| | ours | RTAB-Map 0.23.8 |\n|---|---|---|")
    print(
        f"| ATE, every pose written (cm) | {cm(ours_block['ate'])} ({ours_block['frames_with_pose']} poses) "
        f"| {cm(ref_block['ate'])} ({ref_block['frames_with_pose']} poses) |"
    )
    print(
        f"| ATE over the graph nodes (cm) | {cm(ours_block['node_ate'])} ({ours_block['keyframes']} nodes) "
        f"| {cm(ref_block['ate'])} ({reference_summary.get('db', {}).get('nodes', '?')} nodes) |"
    )
    print(
        f"| odometry alone (cm) | {cm(ours_block['odometry_ate'])} "
        f"| {cm(blocks[REFERENCE_NAME + '-odometry']['ate'])} (nodes' odometry) |"
    )
    print(
        f"| odometry, frame to frame: translation error mean / median (cm) | "
        f"{frame_to_frame(ours.odometry, sequence)} "
        f"| {frame_to_frame(replays[REFERENCE_NAME + '-odometry'].trajectory, sequence)} |"
    )
    print(
        f"| global loop closures (appearance) | {detections.get('appearance', {}).get('accepted', 0)} accepted, "
        f"{detections.get('appearance', {}).get('rejected', 0)} rejected | {links.get('global_loop', 0)} |"
    )
    print(f"| proximity links | {detections.get('proximity', {}).get('accepted', 0)} | {links.get('local_space', 0)} |")
    print(
        f"| edges by kind (sequential / local / loop) | {ours_block['edges']['sequential']} / "
        f"{ours_block['edges']['local']} / {ours_block['edges']['loop']} | – |"
    )
    print(f"| coverage | {ours_block['coverage']['ratio']:.1%} | {ref_block['coverage']['ratio']:.1%} |")
    print(
        "\nPer frame (frames where both have the statistic): sum and median ours / reference, share of "
        "frames that agree, first frame they diverge (inliers, features, local map: off by over 20 % and 2; "
        "decisions and link counts: any difference), largest difference.\n"
    )
    print("| statistic | sum | median | agree | first divergence | largest |\n|---|---|---|---|---|---|")
    for key in ("inliers", "features", "local_map", "key_frame", "loop_accepted", "loop_rejected", "proximity"):
        print(divergence(key, our[key], ref[key]))
    rows = frame_rows(run)
    resumed = resumptions(rows)
    if resumed:
        ours_resumed = [
            (e.frame_index, int(our["inliers"][e.frame_index])) for e in events if isinstance(e, TrackingRecovered)
        ]
        print(
            f"\nodometry resumes after a loss at frame (inliers): ours {ours_resumed or 'never'}; "
            f"RTAB-Map 0.23.8 {resumed}"
        )
        before = first_loss(rows)
        if before is not None:
            theirs = replays[f"{REFERENCE_NAME}-odometry"].trajectory
            print(
                f"odometry position error (cm; laid onto the groundtruth by its poses before the first loss, "
                f"frame {before}): ours {resumption_errors(ours.odometry, sequence, before, [f for f, _ in ours_resumed])}; "
                f"RTAB-Map 0.23.8 {resumption_errors(theirs, sequence, before, [f for f, _ in resumed])}"
            )
    print()
    print(pose_divergence(ours.odometry, replays[f"{REFERENCE_NAME}-odometry"].trajectory, sequence, "odometry"))
    print(pose_divergence(ours.trajectory, replays[REFERENCE_NAME].trajectory, sequence, "graph"))
    print(f"\nreport: {report_path}\n  viewslam diff {report_path} {report_path} --runs {REFERENCE_NAME}:rtabmap")
    return {
        "run": run.name,
        "ours": {
            "ate": ours_block["ate"],
            "node_ate": ours_block["node_ate"],
            "odometry_ate": ours_block["odometry_ate"],
            "edges_by_detection": detections,
        },
        "reference": {
            "ate": ref_block["ate"],
            "odometry_ate": blocks[REFERENCE_NAME + "-odometry"]["ate"],
            "links": links,
        },
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.like_for_like", description=__doc__.split("\n\n")[0])
    parser.add_argument("runs", nargs="*", help="reference run folders (or parts of their names); default: all found")
    parser.add_argument("--reference", type=Path, default=REFERENCE)
    parser.add_argument("--tum", type=Path, default=TUM, help="folder holding the shared TUM excerpts")
    parser.add_argument("--synthetic", type=Path, help="folder holding the rendered synthetic scenes")
    parser.add_argument("--out", type=Path, default=Path("recordings/like_for_like"))
    lab.add_parameter_options(parser, "ours, on top of the reference's configuration")
    parser.add_argument("--diff", action="store_true", help="also print `viewslam diff` of ours against the original")
    args = parser.parse_args(argv)
    runs = [
        run
        for run in reference_runs(args.reference)
        if not args.runs or any(wanted in run.name for wanted in args.runs)
    ]
    if not args.synthetic:
        runs = [run for run in runs if not run.synthetic] if not args.runs else runs
    if not runs:
        raise InputError(
            f"{args.reference}: no reference run" + (f" named like {', '.join(args.runs)}" if args.runs else "")
        )
    for run in runs:
        summary = compare(run, frames_folder(run, args.tum, args.synthetic), args.out, args)
        if args.diff:
            report = args.out / f"{run.name}.json"
            print_comparison(compare_reports(report, report, (REFERENCE_NAME, "rtabmap")))
        (args.out / f"{run.name}.summary.json").write_text(json.dumps(summary, indent=2, default=float) + "\n")
    return 0


if __name__ == "__main__":
    lab.main_of(main)
