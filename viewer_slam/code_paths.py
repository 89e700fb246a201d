"""One code path through NumPy, OpenBLAS and OpenCV on every x86-64 CPU with AVX2, so that a
run gives the same bytes on every such machine.

All three pick their code for the processor when they are first loaded. On a processor with
AVX-512, NumPy's sine, cosine, exponential, logarithm and their kin run AVX-512 code
(derived from Intel's SVML) whose last bits differ from those of the AVX2 and scalar code
that a processor without AVX-512 runs; the synthetic scenes' textures, camera paths and
moving people are made with them, so a scene would render differently on the two. OpenBLAS
likewise runs other kernels there (SkylakeX, Cooperlake, Sapphire Rapids), which round the
small products and decompositions of the evaluation (the alignment's SVD) differently from
its Haswell kernels, and OpenCV's AVX-512 code moves rtabmap's poses in their last bits.
viewslam holds NumPy to its AVX2 loops (dispatch level ``X86_V3``, by
``NPY_DISABLE_CPU_FEATURES``), OpenBLAS to its Haswell kernels (``OPENBLAS_CORETYPE``) and
OpenCV to its AVX2 code (``OPENCV_CPU_DISABLE``), which they read once, when first
imported: importing :mod:`viewer_slam` sets them before anything of viewslam imports NumPy
or OpenCV, and the processes viewslam starts (render and benchmark pools, Ray workers)
inherit them or are handed them. A program that imported NumPy before viewslam keeps the
processor's own code paths, and is warned.

numba's target needs no hold: measured, it does not change a run (``scripts/reference_runs.py
--check --emulate all``), and the renderer casts its rays in code of its own
(``dataset/synth/raycast.py``).
"""

import importlib
import os
import platform
import sys
import warnings
from functools import cache
from pathlib import Path

#: NumPy's dispatch targets beyond AVX2: AVX-512 (Skylake-X), its Ice Lake and Sapphire Rapids extensions.
NUMPY_BEYOND_AVX2 = ("X86_V4", "AVX512_ICL", "AVX512_SPR")
OPENBLAS_KERNELS = "Haswell"  # OpenBLAS's kernels for AVX2 with FMA (Zen runs the same)
_SKX = ("avx512f", "avx512cd", "avx512bw", "avx512dq", "avx512vl")
_CNL = (*_SKX, "avx512ifma", "avx512vbmi")
_CLX = (*_SKX, "avx512_vnni")
#: OpenCV's AVX-512 dispatch levels, by its names, with the CPU flags each needs. Only those this
#: CPU has are disabled: naming one it lacks makes OpenCV print a warning at every start.
OPENCV_AVX512 = {
    "AVX512F": ("avx512f",),
    "AVX512-COMMON": ("avx512f", "avx512cd"),
    "AVX512-SKX": _SKX,
    "AVX512-CNL": _CNL,
    "AVX512-CLX": _CLX,
    "AVX512-ICL": (*_CNL, *_CLX, "avx512_vbmi2", "avx512_bitalg", "avx512_vpopcntdq", "vaes", "gfni", "vpclmulqdq"),
}


@cache
def cpu_flags() -> frozenset[str]:
    """This CPU's feature flags as Linux names them (``avx2``, ``avx512f``...); empty where
    the system does not tell."""
    try:
        lines = Path("/proc/cpuinfo").read_text().splitlines()
    except OSError:
        return frozenset()
    return frozenset(next((line.split(":", 1)[1].split() for line in lines if line.startswith("flags")), []))


def _x86_64() -> bool:
    return platform.machine().lower() in ("x86_64", "amd64")


def guaranteed() -> bool:
    """Whether the same bytes are guaranteed on this CPU: x86-64 with AVX2 and FMA (assumed
    not where the system does not tell)."""
    return _x86_64() and {"avx2", "fma"} <= cpu_flags()


def environment() -> dict[str, str]:
    """The variables that hold a new process to the one code path (empty where the
    guarantee does not apply)."""
    if not guaranteed():
        return {}
    disabled = os.environ.get("NPY_DISABLE_CPU_FEATURES", "").replace(",", " ").split()
    held = {
        "NPY_DISABLE_CPU_FEATURES": " ".join(disabled + [t for t in NUMPY_BEYOND_AVX2 if t not in disabled]),
        "OPENBLAS_CORETYPE": OPENBLAS_KERNELS,
    }
    opencv = [name for name, needs in OPENCV_AVX512.items() if cpu_flags().issuperset(needs)]
    if opencv:
        off = os.environ.get("OPENCV_CPU_DISABLE", "").replace(" ", ",").split(",")
        held["OPENCV_CPU_DISABLE"] = ",".join([name for name in off if name] + [n for n in opencv if n not in off])
    return held


def hold() -> None:
    """Hold this process (if NumPy is not imported yet) and its children to the one code
    path; warn once if NumPy was imported before and runs beyond it."""
    held = environment()
    os.environ.update(held)
    if "numpy" in sys.modules and numpy_level() in NUMPY_BEYOND_AVX2:
        settings = " ".join(f"{name}={value!r}" for name, value in held.items())
        warnings.warn(
            "NumPy was imported before viewer_slam and runs its AVX-512 code, so results may differ in "
            f"the last bits from other machines'; import viewer_slam first, or set {settings}",
            RuntimeWarning,
            stacklevel=3,
        )


def numpy_level() -> str | None:
    """The highest of NumPy's dispatch targets in force in this process (None off x86-64)."""
    if not _x86_64():
        return None
    core = importlib.import_module("numpy._core._multiarray_umath")  # NumPy's own record of its dispatch
    enabled = [target for target in core.__cpu_dispatch__ if core.__cpu_features__.get(target)]
    return enabled[-1] if enabled else "X86_V2"
