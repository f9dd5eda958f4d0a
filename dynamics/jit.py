"""The one way kernels are compiled: numba, cached to disk, GIL released.

``error_model="numpy"`` drops Python's zero-division checks from the inner loops; fastmath allows fused
multiply-adds and reassociation but keeps IEEE nan/inf semantics, so non-finite results stay detectable.
"""

from numba import njit

FASTMATH = {"contract", "reassoc", "nsz", "arcp"}

kernel = njit(cache=True, nogil=True, error_model="numpy", fastmath=FASTMATH)
