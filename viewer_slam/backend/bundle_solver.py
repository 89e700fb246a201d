"""g2o's Levenberg-Marquardt on one frame and its points, compiled (see ``local_bundle``).

Everything inside an iteration is here, in one compiled loop: a bundle of a few hundred
edges is too small for NumPy, whose per-call overhead then outweighs the arithmetic.

The edges come sorted by point, which fixes the order of every per-point sum. ``camera``
is ``(fx, fy, cx, cy, baseline, pixel_variance, kernel_delta)``; a link of information 0
is no link. ``held_rotation`` and ``held_translation`` are each edge's key-frame
world-to-camera transform (unused on the adjusted frame's own edges).
"""

import numpy as np

from ..compiled import jit

LAMBDA_INIT_FACTOR = 1e-5  # g2o's tau: first damping over the largest Hessian diagonal entry
MAX_TRIALS_AFTER_FAILURE = 10  # g2o's maxTrialsAfterFailure
GOOD_STEP_LOWER_SCALE = 1.0 / 3.0
GOOD_STEP_UPPER_SCALE = 2.0 / 3.0
SCALE_EPSILON = 1e-3  # g2o adds it to the predicted decrease "to make sure it's non-zero"


@jit
def huber(chi2, delta):
    """g2o's RobustKernelHuber on chi2: the robust cost rho and its derivative rho' (the
    weight of the edge's information); no kernel when ``delta`` is 0."""
    if delta <= 0.0 or chi2 <= delta * delta:
        return chi2, 1.0
    root = np.sqrt(chi2)
    return 2.0 * delta * root - delta * delta, delta / root


@jit
def quaternion_vector(rotation):
    """Vector part of the unit quaternion of ``rotation`` taken with a non-negative scalar part."""
    w = np.sqrt(max(0.0, 1.0 + rotation[0, 0] + rotation[1, 1] + rotation[2, 2])) / 2.0
    vector = np.empty(3)
    if w > 1e-6:
        vector[0] = (rotation[2, 1] - rotation[1, 2]) / (4.0 * w)
        vector[1] = (rotation[0, 2] - rotation[2, 0]) / (4.0 * w)
        vector[2] = (rotation[1, 0] - rotation[0, 1]) / (4.0 * w)
        return vector
    largest = 0
    for i in range(3):  # a half turn: the axis from the diagonal, signs from the largest row
        vector[i] = np.sqrt(max(0.0, (rotation[i, i] + 1.0) / 2.0))
        if vector[i] > vector[largest]:
            largest = i
    for i in range(3):
        if i != largest:
            vector[i] *= np.sign(rotation[largest, i] + rotation[i, largest])
    return vector


@jit
def quaternion_vector_rotation(vector):
    """Rotation of the unit quaternion with vector part ``vector`` and a non-negative scalar
    part (identity when the vector is not shorter than 1), as g2o's SBACam::update builds it."""
    x, y, z = vector[0], vector[1], vector[2]
    squared = x * x + y * y + z * z
    if squared >= 1.0:
        return np.eye(3)
    w = np.sqrt(1.0 - squared)
    rotation = np.empty((3, 3))
    rotation[0, 0], rotation[0, 1], rotation[0, 2] = 1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)
    rotation[1, 0], rotation[1, 1], rotation[1, 2] = 2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)
    rotation[2, 0], rotation[2, 1], rotation[2, 2] = 2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)
    return rotation


@jit
def updated_pose(pose, step):
    """``T_world_camera`` moved by g2o's camera increment: translation added in the world
    frame, rotation multiplied on the right by the quaternion of vector part ``step[3:]``."""
    turn = quaternion_vector_rotation(step[3:])
    moved = np.eye(4)
    for i in range(3):
        for j in range(3):
            moved[i, j] = pose[i, 0] * turn[0, j] + pose[i, 1] * turn[1, j] + pose[i, 2] * turn[2, j]
        moved[i, 3] = pose[i, 3] + step[i]
    return moved


@jit
def link_error(to_measured, pose):
    """g2o's EdgeSBACam error: translation and quaternion vector part of
    ``measured^-1 T_key^-1 T_adjusted`` (``to_measured`` is ``measured^-1 T_key^-1``)."""
    delta = to_measured @ pose
    error = np.empty(6)
    error[:3] = delta[:3, 3]
    error[3:] = quaternion_vector(delta[:3, :3])
    return error


@jit
def _add_link(to_measured, information, pose, hessian_camera, gradient_camera):
    """The link's J^T J and -J^T e: d error / d camera increment has the measured-to-key
    rotation on the translation; the quaternion (w, a) of the relative rotation times (1, dv)
    has vector part a + w dv + a x dv."""
    error = link_error(to_measured, pose)
    a = error[3:]
    w = np.sqrt(max(0.0, 1.0 - (a[0] * a[0] + a[1] * a[1] + a[2] * a[2])))
    jacobian = np.zeros((6, 6))
    jacobian[:3, :3] = to_measured[:3, :3]
    jacobian[3, 3], jacobian[3, 4], jacobian[3, 5] = w, -a[2], a[1]
    jacobian[4, 3], jacobian[4, 4], jacobian[4, 5] = a[2], w, -a[0]
    jacobian[5, 3], jacobian[5, 4], jacobian[5, 5] = -a[1], a[0], w
    weighted = jacobian.T * information  # J^T diag(information)
    hessian_camera += weighted @ jacobian
    gradient_camera -= weighted @ error


@jit
def evaluate(
    pose,
    points,
    kept,
    point,
    free,
    stereo,
    measured,
    held_rotation,
    held_translation,
    camera,
    link_to_measured,
    link_information,
    in_camera,
    error,
    chi2,
):
    """Fills each edge's camera-frame point, error (predicted minus measured u, v and, with
    depth, u - fx b / z) and chi2 (squared error over the pixel variance); returns g2o's
    activeRobustChi2: the Huber costs of the kept edges plus the link's chi2."""
    fx, fy, cx, cy, baseline, pixel_variance, delta = (
        camera[0],
        camera[1],
        camera[2],
        camera[3],
        camera[4],
        camera[5],
        camera[6],
    )
    rotation, translation = pose[:3, :3], pose[:3, 3]
    cost = 0.0
    for m in range(len(point)):
        p = points[point[m]]
        for i in range(3):
            if free[m]:
                in_camera[m, i] = (
                    rotation[0, i] * (p[0] - translation[0])
                    + rotation[1, i] * (p[1] - translation[1])
                    + rotation[2, i] * (p[2] - translation[2])
                )
            else:
                in_camera[m, i] = (
                    held_rotation[m, i, 0] * p[0]
                    + held_rotation[m, i, 1] * p[1]
                    + held_rotation[m, i, 2] * p[2]
                    + held_translation[m, i]
                )
        inverse_z = 1.0 / in_camera[m, 2]
        u = fx * in_camera[m, 0] * inverse_z + cx
        error[m, 0] = u - measured[m, 0]
        error[m, 1] = fy * in_camera[m, 1] * inverse_z + cy - measured[m, 1]
        error[m, 2] = u - fx * baseline * inverse_z - measured[m, 2] if stereo[m] else 0.0
        chi2[m] = (error[m, 0] ** 2 + error[m, 1] ** 2 + error[m, 2] ** 2) / pixel_variance
        if kept[m]:
            cost += huber(chi2[m], delta)[0]
    if link_information.any():
        link = link_error(link_to_measured, pose)
        cost += np.sum(link_information * link * link)
    return cost


@jit
def _normal_equations(
    pose,
    kept,
    point,
    free,
    stereo,
    held_rotation,
    camera,
    link_to_measured,
    link_information,
    in_camera,
    error,
    chi2,
    hessian_camera,
    gradient_camera,
    hessian_points,
    gradient_points,
    coupling,
):
    """The Gauss-Newton system of the kept edges in blocks (b is minus the gradient), each
    edge's information weighed by the Huber kernel. J is the projection's Jacobian (u, v and,
    with depth, u_right) times d(camera-frame point) / d(point) = the edge camera's
    world-to-camera rotation and, for the adjusted frame, / d(t, dv) = (-R^T, 2 [p]x) for
    g2o's camera increment."""
    fx, fy, baseline, pixel_variance, delta = camera[0], camera[1], camera[4], camera[5], camera[6]
    hessian_camera[:] = 0.0
    gradient_camera[:] = 0.0
    hessian_points[:] = 0.0
    gradient_points[:] = 0.0
    coupling[:] = 0.0
    pose_to_camera = np.ascontiguousarray(pose[:3, :3].T)
    projection = np.zeros((3, 3))
    point_jacobian = np.empty((3, 3))
    camera_jacobian = np.empty((3, 6))
    for m in range(len(point)):
        if not kept[m]:
            continue
        w = huber(chi2[m], delta)[1] / pixel_variance
        x, y, z = in_camera[m, 0], in_camera[m, 1], in_camera[m, 2]
        inverse_z = 1.0 / z
        projection[0, 0] = fx * inverse_z
        projection[0, 2] = -fx * x * inverse_z**2
        projection[1, 1] = fy * inverse_z
        projection[1, 2] = -fy * y * inverse_z**2
        rows = 3 if stereo[m] else 2
        projection[2, 0] = fx * inverse_z
        projection[2, 2] = -fx * (x - baseline) * inverse_z**2
        rotation = pose_to_camera if free[m] else held_rotation[m]
        for i in range(rows):
            for j in range(3):
                point_jacobian[i, j] = (
                    projection[i, 0] * rotation[0, j]
                    + projection[i, 1] * rotation[1, j]
                    + projection[i, 2] * rotation[2, j]
                )
        p = point[m]
        for a in range(3):
            for b in range(3):
                total = 0.0
                for i in range(rows):
                    total += point_jacobian[i, a] * point_jacobian[i, b]
                hessian_points[p, a, b] += w * total
            total = 0.0
            for i in range(rows):
                total += point_jacobian[i, a] * error[m, i]
            gradient_points[p, a] -= w * total
        if not free[m]:
            continue
        for i in range(rows):  # (-R^T, 2 [p]x)
            for j in range(3):
                camera_jacobian[i, j] = -point_jacobian[i, j]
            camera_jacobian[i, 3] = 2.0 * (projection[i, 1] * z - projection[i, 2] * y)
            camera_jacobian[i, 4] = 2.0 * (projection[i, 2] * x - projection[i, 0] * z)
            camera_jacobian[i, 5] = 2.0 * (projection[i, 0] * y - projection[i, 1] * x)
        for a in range(6):
            for b in range(6):
                total = 0.0
                for i in range(rows):
                    total += camera_jacobian[i, a] * camera_jacobian[i, b]
                hessian_camera[a, b] += w * total
            total = 0.0
            for i in range(rows):
                total += camera_jacobian[i, a] * error[m, i]
            gradient_camera[a] -= w * total
            for b in range(3):
                total = 0.0
                for i in range(rows):
                    total += camera_jacobian[i, a] * point_jacobian[i, b]
                coupling[p, a, b] += w * total
    if link_information.any():
        _add_link(link_to_measured, link_information, pose, hessian_camera, gradient_camera)


@jit
def _inverse_3x3(a, inverse):
    """Fills ``inverse`` by the adjugate (as Eigen inverts a 3x3); False when ``a`` is singular."""
    inverse[0, 0] = a[1, 1] * a[2, 2] - a[1, 2] * a[2, 1]
    inverse[0, 1] = a[0, 2] * a[2, 1] - a[0, 1] * a[2, 2]
    inverse[0, 2] = a[0, 1] * a[1, 2] - a[0, 2] * a[1, 1]
    inverse[1, 0] = a[1, 2] * a[2, 0] - a[1, 0] * a[2, 2]
    inverse[1, 1] = a[0, 0] * a[2, 2] - a[0, 2] * a[2, 0]
    inverse[1, 2] = a[0, 2] * a[1, 0] - a[0, 0] * a[1, 2]
    inverse[2, 0] = a[1, 0] * a[2, 1] - a[1, 1] * a[2, 0]
    inverse[2, 1] = a[0, 1] * a[2, 0] - a[0, 0] * a[2, 1]
    inverse[2, 2] = a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]
    determinant = a[0, 0] * inverse[0, 0] + a[0, 1] * inverse[1, 0] + a[0, 2] * inverse[2, 0]
    if not abs(determinant) > 0.0:
        return False
    inverse /= determinant
    return True


@jit
def _cholesky_solve(matrix, rhs):
    """x with ``matrix x = rhs`` for a symmetric positive definite ``matrix`` (g2o's linear
    solvers are Cholesky factorisations); None when it is not positive definite."""
    n = len(rhs)
    lower = np.zeros((n, n))
    for j in range(n):
        for i in range(j, n):
            total = matrix[i, j]
            for k in range(j):
                total -= lower[i, k] * lower[j, k]
            if i == j:
                if not total > 0.0:
                    return None
                lower[j, j] = np.sqrt(total)
            else:
                lower[i, j] = total / lower[j, j]
    solution = rhs.copy()
    for i in range(n):
        for k in range(i):
            solution[i] -= lower[i, k] * solution[k]
        solution[i] /= lower[i, i]
    for i in range(n - 1, -1, -1):
        for k in range(i + 1, n):
            solution[i] -= lower[k, i] * solution[k]
        solution[i] /= lower[i, i]
    return solution


@jit
def _schur_step(
    hessian_camera, gradient_camera, hessian_points, gradient_points, coupling, damping, active, inverses, point_step
):
    """The camera step of the damped system (H + damping I) dx = b with the points eliminated
    first, and each active point's step into ``point_step`` (inactive points do not move);
    None when the system cannot be solved. ``inverses`` is scratch space, a 3x3 per point."""
    reduced = hessian_camera + damping * np.eye(6)
    rhs = gradient_camera.copy()
    damped = np.empty((3, 3))
    coupled = np.empty((6, 3))
    for k in range(len(active)):
        if not active[k]:
            continue
        damped[:] = hessian_points[k]
        for i in range(3):
            damped[i, i] += damping
        if not _inverse_3x3(damped, inverses[k]):
            return None
        for a in range(6):
            for j in range(3):
                coupled[a, j] = (
                    coupling[k, a, 0] * inverses[k, 0, j]
                    + coupling[k, a, 1] * inverses[k, 1, j]
                    + coupling[k, a, 2] * inverses[k, 2, j]
                )
            for b in range(6):
                reduced[a, b] -= (
                    coupled[a, 0] * coupling[k, b, 0]
                    + coupled[a, 1] * coupling[k, b, 1]
                    + coupled[a, 2] * coupling[k, b, 2]
                )
            rhs[a] -= (
                coupled[a, 0] * gradient_points[k, 0]
                + coupled[a, 1] * gradient_points[k, 1]
                + coupled[a, 2] * gradient_points[k, 2]
            )
    camera_step = _cholesky_solve(reduced, rhs)
    if camera_step is None:
        return None
    remaining = np.empty(3)
    for k in range(len(active)):
        if not active[k]:
            point_step[k] = 0.0
            continue
        for j in range(3):
            remaining[j] = gradient_points[k, j]
            for a in range(6):
                remaining[j] -= coupling[k, a, j] * camera_step[a]
        for i in range(3):
            point_step[k, i] = (
                inverses[k, i, 0] * remaining[0] + inverses[k, i, 1] * remaining[1] + inverses[k, i, 2] * remaining[2]
            )
    return camera_step


@jit
def _predicted_decrease(camera_step, point_step, gradient_camera, gradient_points, damping, active):
    """g2o's computeScale: dx . (damping dx + b) over the camera and the active points."""
    decrease = 0.0
    for i in range(6):
        decrease += camera_step[i] * (damping * camera_step[i] + gradient_camera[i])
    for k in range(len(active)):
        if active[k]:
            for i in range(3):
                decrease += point_step[k, i] * (damping * point_step[k, i] + gradient_points[k, i])
    return decrease


@jit
def levenberg_marquardt(
    pose,
    points,
    kept,
    iterations,
    point,
    free,
    stereo,
    measured,
    held_rotation,
    held_translation,
    camera,
    link_to_measured,
    link_information,
):
    """g2o's OptimizationAlgorithmLevenberg over the kept edges: the first damping is
    LAMBDA_INIT_FACTOR times the largest Hessian diagonal entry; a step is kept when it lowers
    the robust chi2, the damping then scaled by max(1/3, min(2/3, 1 - (2 rho - 1)^3)), and
    otherwise undone with the damping multiplied by 2, 4, 8, ... for at most
    MAX_TRIALS_AFTER_FAILURE trials, after which the pass ends. Returns the pose, the points
    and every edge's chi2 there (kept or not)."""
    edges, count = len(point), len(points)
    active = np.zeros(count, np.bool_)
    for m in range(edges):
        if kept[m]:
            active[point[m]] = True
    in_camera, error, chi2 = np.empty((edges, 3)), np.empty((edges, 3)), np.empty(edges)
    trial_in_camera, trial_error, trial_chi2 = np.empty((edges, 3)), np.empty((edges, 3)), np.empty(edges)
    hessian_camera, gradient_camera = np.zeros((6, 6)), np.zeros(6)
    hessian_points, gradient_points, coupling = np.zeros((count, 3, 3)), np.zeros((count, 3)), np.zeros((count, 6, 3))
    point_step, inverses = np.zeros((count, 3)), np.zeros((count, 3, 3))
    cost = evaluate(
        pose,
        points,
        kept,
        point,
        free,
        stereo,
        measured,
        held_rotation,
        held_translation,
        camera,
        link_to_measured,
        link_information,
        in_camera,
        error,
        chi2,
    )
    damping, growth = 0.0, 2.0
    trial_pose, trial_points, trial_cost = pose, points, cost
    for iteration in range(iterations):
        _normal_equations(
            pose,
            kept,
            point,
            free,
            stereo,
            held_rotation,
            camera,
            link_to_measured,
            link_information,
            in_camera,
            error,
            chi2,
            hessian_camera,
            gradient_camera,
            hessian_points,
            gradient_points,
            coupling,
        )
        if iteration == 0:
            largest = 0.0
            for i in range(6):
                largest = max(largest, hessian_camera[i, i])
            for k in range(count):
                if active[k]:
                    for i in range(3):
                        largest = max(largest, hessian_points[k, i, i])
            damping, growth = LAMBDA_INIT_FACTOR * largest, 2.0
        trials, gain = 0, -1.0
        while gain < 0 and trials < MAX_TRIALS_AFTER_FAILURE:
            camera_step = _schur_step(
                hessian_camera,
                gradient_camera,
                hessian_points,
                gradient_points,
                coupling,
                damping,
                active,
                inverses,
                point_step,
            )
            gain = -np.inf
            if camera_step is not None:
                trial_pose, trial_points = updated_pose(pose, camera_step), points + point_step
                trial_cost = evaluate(
                    trial_pose,
                    trial_points,
                    kept,
                    point,
                    free,
                    stereo,
                    measured,
                    held_rotation,
                    held_translation,
                    camera,
                    link_to_measured,
                    link_information,
                    trial_in_camera,
                    trial_error,
                    trial_chi2,
                )
                if np.isfinite(trial_cost):
                    decrease = _predicted_decrease(
                        camera_step, point_step, gradient_camera, gradient_points, damping, active
                    )
                    gain = (cost - trial_cost) / (decrease + SCALE_EPSILON)
            if gain > 0:
                damping *= max(GOOD_STEP_LOWER_SCALE, min(GOOD_STEP_UPPER_SCALE, 1 - (2 * gain - 1) ** 3))
                growth, pose, points, cost = 2.0, trial_pose, trial_points, trial_cost
                in_camera, trial_in_camera = trial_in_camera, in_camera
                error, trial_error = trial_error, error
                chi2, trial_chi2 = trial_chi2, chi2
            else:
                damping *= growth
                growth *= 2
            trials += 1
        if trials == MAX_TRIALS_AFTER_FAILURE or gain == 0 or not np.isfinite(damping):
            break
    return pose, points, chi2
