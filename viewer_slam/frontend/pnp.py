"""3D-2D registration: OpenCV's PnP RANSAC, refined on its inliers."""

from dataclasses import dataclass

import cv2
import numpy as np

from ..geometry.se3 import invert, make_pose

RANSAC_CONFIDENCE = 0.99


@dataclass
class PnpResult:
    """``pose`` is the camera in the frame of the 3D points (``T_points_camera``)."""

    pose: np.ndarray
    inliers: np.ndarray

    @property
    def inlier_count(self) -> int:
        return int(self.inliers.sum())


def solve_pnp_ransac(object_points: np.ndarray, image_points: np.ndarray, K: np.ndarray, *,
                     reprojection_error: float, iterations: int, min_inliers: int,
                     distortion: tuple[float, ...] | None = None) -> PnpResult | None:
    """Camera pose from 3D points ``(N, 3)`` seen at pixels ``(N, 2)``, or None when fewer
    than ``min_inliers`` correspondences agree.

    RANSAC hypotheses come from the minimal AP3P solver (four points, so far fewer
    iterations than EPnP's five at the same confidence). The pose is then fitted afresh to
    RANSAC's inliers by SQPnP and refined by Levenberg-Marquardt, and the inliers are
    recounted. OpenCV's own final fit on the inliers is EPnP, which on points that lie
    nearly on one plane can return a pose that reprojects almost none of them (on OpenCV
    4.14, 1 of 68 inliers of a texture-less floor within the threshold); SQPnP is
    globally optimal for any point layout, so the result no longer hinges on that step of
    the OpenCV release. OpenCV draws its samples
    from a generator of the call's own with a fixed seed, not from the global one
    ``cv2.setRNGSeed`` sets, so the same input always gives the same pose and no seed
    applies (as in RTAB-Map itself, which calls the same function). ``distortion``
    (OpenCV's k1, k2, p1, p2, k3) is the lens model of the pixels: TUM's freiburg1/2 images
    are not rectified.
    """
    if len(object_points) < max(min_inliers, 4):
        return None
    object_points = np.ascontiguousarray(object_points, dtype=np.float64)
    image_points = np.ascontiguousarray(image_points, dtype=np.float64)
    lens = np.asarray(distortion, dtype=np.float64) if distortion is not None and any(distortion) else None
    ok, rvec, tvec, inliers = cv2.solvePnPRansac(
        object_points, image_points, K, lens, iterationsCount=iterations, reprojectionError=reprojection_error,
        confidence=RANSAC_CONFIDENCE, flags=cv2.SOLVEPNP_AP3P)
    if not ok or inliers is None or len(inliers) < min_inliers:
        return None
    inliers = inliers.ravel()
    _, rvec, tvec = cv2.solvePnP(object_points[inliers], image_points[inliers], K, lens, flags=cv2.SOLVEPNP_SQPNP)
    rvec, tvec = cv2.solvePnPRefineLM(object_points[inliers], image_points[inliers], K, lens, rvec, tvec)
    projected = cv2.projectPoints(object_points, rvec, tvec, K, lens)[0].reshape(-1, 2)
    mask = np.linalg.norm(projected - image_points, axis=1) <= reprojection_error
    if mask.sum() < min_inliers:
        return None
    return PnpResult(invert(make_pose(cv2.Rodrigues(rvec)[0], tvec.ravel())), mask)
