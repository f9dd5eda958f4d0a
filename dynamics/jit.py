"""The one way kernels are compiled: numba, cached to disk, GIL released.

``error_model="numpy"`` drops Python's zero-division checks from the inner loops.  fastmath stays off:
with strict IEEE arithmetic a state gives bit-identical results whether it is computed alone, in a batch
or inside a simulation (reassociation would let each inlining context round differently).
"""

from numba import njit

kernel = njit(cache=True, nogil=True, error_model="numpy")
