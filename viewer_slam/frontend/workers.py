"""The process's worker threads, for work that releases the GIL (OpenCV, the compiled
kernels, GTSAM's optimiser).

One pool serves the whole process: each thread that allocates gets a malloc arena of its
own, and memory freed in one arena is not reused by another, so more threads raise the
peak memory (capping the arenas at two lowered a 800-frame run's peak from 666 to 600 MB).
Tasks on the pool never wait for other tasks on it.
"""

from concurrent.futures import ThreadPoolExecutor
from functools import cache

WORKER_THREADS = 2


@cache
def workers() -> ThreadPoolExecutor:
    return ThreadPoolExecutor(WORKER_THREADS, thread_name_prefix="viewslam-worker")
