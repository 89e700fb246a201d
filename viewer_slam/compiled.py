"""The one way viewslam compiles its inner loops: numba, cached on disk, the GIL released.

Released so that two threads run compiled work on two cores; NumPy's error model, so a
division by zero gives inf or NaN (which the callers test for) instead of raising inside a
thread that holds no GIL.
"""

import numba

jit = numba.njit(cache=True, nogil=True, error_model="numpy")
