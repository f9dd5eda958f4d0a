"""Give freed memory back to the operating system, so that the server's RSS returns to its baseline.

glibc's malloc raises its mmap threshold after a large block is freed (up to 32 MiB), so the next large arrays
come from the heap and stay mapped after they are freed: a request that used 4 GB left the process at 4 GB.
:func:`configure` fixes the threshold (large blocks always mmapped, returned on free) and :func:`release`
collects young reference cycles and trims the heap after a large answer or a 504, once the answer is sent.
Both do nothing where glibc is absent.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools
import gc

M_MMAP_THRESHOLD = -3
#: answers past this size are followed by a trim of the heap once sent (service.codec.encode)
RELEASE_BYTES = 16 * 1024 * 1024
#: blocks from this size on are mmapped (and unmapped when freed): numpy arrays of states, answers, bodies
MMAP_THRESHOLD = 1 << 20


@functools.cache
def _libc():
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        libc.mallopt, libc.malloc_trim  # (AttributeError off glibc)
        return libc
    except (OSError, AttributeError):
        return None


def configure() -> None:
    libc = _libc()
    if libc is not None:
        libc.mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD)


def release() -> None:
    # The young generations only: a stopped request's arrays are held by reference cycles made during the
    # request (the library's stopped pieces and their exceptions), and a full collection walks every
    # long-lived object of the process (~100 ms here; after every 504 it cut a soak's throughput).
    gc.collect(1)
    libc = _libc()
    if libc is not None:
        libc.malloc_trim(0)
