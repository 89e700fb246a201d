"""One registration of viewslam's rtabmap odometry beside the real RTAB-Map's, on the same frames.

    python -m benchmarks.first_registration                  # frame 1 of fr1/rpy, 200 frames
    python -m benchmarks.first_registration --frame 2 --run rgbd_dataset_freiburg1_rpy_200-perframe

Frames 0 to ``--frame`` go through our frame-to-map odometry in the original's configuration
(its intrinsics without distortion, OdomF2M/BundleAdjustment 0, then ``--config`` and ``--param``;
see like_for_like). The odometry is stepped frame by frame, not run: its local map is read
before each registration. For the
last frame it prints our matches and inliers, the inliers a long RANSAC alone finds among
our matches (RANSAC_ITERATIONS hypotheses, no refit), and, under the original's own pose for
that frame (its odometry, relative to frame 0) and under ours, how many points of our local
map have a corner of the frame within 1 and 2 pixels of their projection: an upper bound on
the inliers our map and corners allow at that pose, whatever the matching; and the most any
pose near the original's allows within the inlier distance (Vis/PnPReprojError squared, as
RTAB-Map's RANSAC counts). Beside it, the inliers the original reports. Where that most is
below its count, the two differ before matching: in the corners or in the map's 3D points.
"""

import argparse
from pathlib import Path

import viewer_slam.code_paths  # noqa: F401  (before NumPy loads: holds it to one code path)

import cv2
import numpy as np
from scipy.spatial import cKDTree

from viewer_slam.dataset.sources import open_source
from viewer_slam.errors import InputError
from viewer_slam.geometry.se3 import invert, transform_points
from viewer_slam.geometry.trajectory import read_tum
from viewer_slam.pipelines.rtabmap.pipeline import Rtabmap

from . import lab
from .figures import TUM
from .reference import REFERENCE, THAT_BUILD, ReferenceRun, number, read_nodes, reference_camera

RANSAC_ITERATIONS = 20_000
RADII_PX = (1.0, 2.0)
PAIRING_RADIUS_PX = 8.0


def corners_near(camera, points: np.ndarray, pose: np.ndarray, corners: np.ndarray) -> list[int]:
    """Per radius of RADII_PX: the map points in front of the camera at ``pose`` whose
    projection has a corner within that radius."""
    in_camera = transform_points(invert(pose), points)
    in_front = in_camera[:, 2] > 0
    distance, _ = cKDTree(corners).query(camera.project(in_camera[in_front]))
    return [int((distance < radius).sum()) for radius in RADII_PX]


def most_near_any_pose(camera, points: np.ndarray, pose: np.ndarray, corners: np.ndarray, threshold: float) -> int:
    """The most map points any pose brings within ``threshold`` pixels of a corner, searched
    around ``pose``: every pairing of a map point with a corner within PAIRING_RADIUS_PX of its
    projection there is a candidate, and RANSAC finds the pose most of them agree with."""
    in_camera = transform_points(invert(pose), points)
    in_front = np.flatnonzero(in_camera[:, 2] > 0)
    near = cKDTree(corners).query_ball_point(camera.project(in_camera[in_front]), PAIRING_RADIUS_PX)
    point_index = np.repeat(in_front, [len(found) for found in near])
    corner_index = np.concatenate([np.asarray(found, int) for found in near])
    return best_consensus(camera, points[point_index], corners[corner_index], threshold)


def best_consensus(camera, object_points: np.ndarray, image_points: np.ndarray, threshold: float) -> int:
    """The inliers of the best of RANSAC_ITERATIONS AP3P hypotheses among the matches, without
    the refit on them that the odometry makes."""
    ok, _, _, inliers = cv2.solvePnPRansac(
        object_points.astype(np.float64),
        image_points.astype(np.float64),
        camera.K,
        None,
        iterationsCount=RANSAC_ITERATIONS,
        reprojectionError=threshold,
        confidence=0.99999,
        flags=cv2.SOLVEPNP_AP3P,
    )
    return len(inliers) if ok and inliers is not None else 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.first_registration",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "--run",
        default="rgbd_dataset_freiburg1_rpy_200-perframe",
        help="reference run folder under --reference (a TUM sequence's)",
    )
    parser.add_argument("--reference", type=Path, default=REFERENCE)
    parser.add_argument("--tum", type=Path, default=TUM)
    parser.add_argument("--frame", type=int, default=1, help="the registration to look at (frame index, >= 1)")
    lab.add_parameter_options(parser, "our odometry, on top of the reference's configuration")
    args = parser.parse_args(argv)
    if args.frame < 1:
        parser.error("--frame: 1 or more (frame 0 starts the map)")
    name, _, mode = args.run.rpartition("-")
    run = ReferenceRun(args.reference / args.run, name, mode, synthetic=False)
    if not run.folder.is_dir():
        raise InputError(f"{run.folder}: no such reference run")
    params = lab.pipeline_spec("rtabmap", args, preset=THAT_BUILD).params
    sequence = open_source(args.tum / name)
    camera = reference_camera(sequence.camera)
    pipeline = Rtabmap(camera, params)
    odometry = pipeline.odometry
    for index in range(args.frame + 1):
        frame = sequence.frame(index)
        features = pipeline.extractor.extract(frame.rgb, frame.depth)
        map_points = odometry.map.points.copy()
        result = odometry.process(features, frame.timestamp)
    if result.pose is None:
        print(f"frame {args.frame}: our odometry found no pose ({result.matches} matches)")
        return 1
    if result.kept is not None:
        features = features.subset(result.kept)

    node = {round(float(row["stamp"]), 4): row for row in read_nodes(run)}.get(round(frame.timestamp, 4))
    reference = read_tum(run.folder / "db_poses_odom_tum.txt")
    first = np.argmin(np.abs(reference.timestamps - sequence.frame(0).timestamp))
    this = np.argmin(np.abs(reference.timestamps - frame.timestamp))
    their_pose = invert(reference.poses[first]) @ reference.poses[this]

    matched = map_points[result.map_index], features.keypoints[result.feature_index]
    print(f"{args.run}, frame {args.frame} ({frame.timestamp:.6f}), local map of {len(map_points)} points")
    print(
        f"  ours: {len(features)} features, {result.matches} matches, {result.inliers} inliers "
        f"(Vis/PnPReprojError {params.pnp_reprojection_error:g}: within {params.pnp_inlier_distance:g} px); "
        f"RANSAC alone, {RANSAC_ITERATIONS} hypotheses: {best_consensus(camera, *matched, params.pnp_inlier_distance)}"
    )
    if node is not None:
        print(
            f"  the original: {number(node['odom_features']):.0f} features, "
            f"{number(node['odom_inliers']):.0f} inliers, local map {number(node['odom_local_map_size']):.0f}"
        )
    radii = " / ".join(f"{radius:g}" for radius in RADII_PX)
    for name, pose in (("the original's pose", their_pose), ("our pose", result.pose)):
        near = " / ".join(str(count) for count in corners_near(camera, map_points, pose, features.keypoints))
        moved = np.linalg.norm(pose[:3, 3]) * 100
        print(f"  under {name} ({moved:.1f} cm from frame 0): map points with a corner within {radii} px: {near}")
    most = most_near_any_pose(camera, map_points, their_pose, features.keypoints, params.pnp_inlier_distance)
    print(
        f"  any pose near the original's: at most {most} map points with a corner within "
        f"{params.pnp_inlier_distance:g} px"
    )
    return 0


if __name__ == "__main__":
    lab.main_of(main)
