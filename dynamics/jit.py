"""The one way kernels are compiled: numba, cached to disk, GIL released.

Kernels read the model's arrays into locals once at their top (``parents, mass = tree.parents, tree.mass``):
every array taken out of a tuple is reference counted with an atomic operation, which inside the per-body
loop cost more than the arithmetic.

``error_model="numpy"`` drops Python's zero-division checks from the inner loops.  fastmath stays off:
with strict IEEE arithmetic a state gives bit-identical results whether it is computed alone, in a batch
or inside a simulation (reassociation would let each inlining context round differently).
"""

from numba import njit

kernel = njit(cache=True, nogil=True, error_model="numpy")

#: for the small helpers called once per body inside the kernels (joint transforms, motion subspaces):
#: inlined by numba itself, so the arrays they read from the model are not reference counted per body
#: (each count is an atomic operation: without this a 2-body RNEA costs 1.4 us instead of 0.3 us)
inline_kernel = njit(cache=True, nogil=True, error_model="numpy", inline="always")
