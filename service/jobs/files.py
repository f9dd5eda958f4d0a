"""Where a job's arrays live, beside the database, and how they are written so that a crash never leaves half.

    <store>/jobs/jobs.db                the records (service.jobs.db)
    <store>/jobs/inputs/<id>.npz        the inputs, written before the job is queued
    <store>/jobs/parts/<id>/<lo>-<hi>.npz   results of the items [lo, hi) done so far (a restart resumes after them)
    <store>/jobs/results/<id>.npz       the result, once done
    <store>/jobs/boots/<boot>.lock      held (flock) by the server process whose jobs run under that boot

Every .npz is written to a temporary name in the same directory, flushed and fsync'ed, renamed over its final
name and the directory fsync'ed (:func:`write_npz`): after a crash a file is wholly there or not at all. A
result is streamed from its parts member by member (:class:`Stacked`), so stacking it takes one part's memory.
Archives are plain ``np.savez`` (no pickles), read back by :mod:`service.npz` (their headers parsed under its
lock: the server reads results on its compute threads); a non-array member (a report) is a 0-d string array
holding JSON, as in the service's .npz answers.
"""

from __future__ import annotations

import shutil
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable, Mapping, NamedTuple

import numpy as np
from numpy.lib import format as npformat

from .. import npz
from ..store import atomic_file


@dataclass(frozen=True)
class JobFiles:
    root: Path  # <store>/jobs

    @classmethod
    def under(cls, store_dir: Path) -> "JobFiles":
        files = cls(Path(store_dir).resolve() / "jobs")
        for sub in ("inputs", "parts", "results", "boots", "incoming"):
            (files.root / sub).mkdir(parents=True, exist_ok=True)
        return files

    @property
    def db(self) -> Path:
        return self.root / "jobs.db"

    @property
    def incoming(self) -> Path:
        """Where .npz bodies are received (anonymous files: nothing is left there after a crash)."""
        return self.root / "incoming"

    def inputs(self, job_id: str) -> Path:
        return self.root / "inputs" / f"{job_id}.npz"

    def parts(self, job_id: str) -> Path:
        return self.root / "parts" / job_id

    def result(self, job_id: str) -> Path:
        return self.root / "results" / f"{job_id}.npz"

    def boot_lock(self, boot: str) -> Path:
        return self.root / "boots" / f"{boot}.lock"

    def remove(self, job_id: str, *, keep_result: bool = False) -> None:
        """A job's files (all, or all but the result); missing ones are fine."""
        shutil.rmtree(self.parts(job_id), ignore_errors=True)
        paths = [self.inputs(job_id)] + ([] if keep_result else [self.result(job_id)])
        for path in paths:
            try:
                path.unlink()
            except FileNotFoundError:
                pass


class Stacked(NamedTuple):
    """A member written chunk by chunk (C order, along the first axis): the result of a job stacked from its
    parts without holding it whole in memory."""
    shape: tuple
    dtype: np.dtype
    chunks: Iterable[np.ndarray]


#: bytes of an array written at once (an array is written in blocks of rows, each from its own memory)
WRITE_BLOCK = 4 << 20


def _blocks(a: np.ndarray) -> Stacked:
    """An array as blocks of rows of about :data:`WRITE_BLOCK` bytes: written without a copy of the whole (a job's
    inputs are as large as its body: numpy's writer would copy each array once more)."""
    rows = max(1, WRITE_BLOCK // max(1, a[:1].nbytes))
    return Stacked(a.shape, a.dtype, (a[i:i + rows] for i in range(0, a.shape[0], rows)))


def write_npz(path: Path, arrays: Mapping[str, Any]) -> int:
    """An .npz archive (uncompressed, as ``np.savez``) at ``path``, atomically and durably; its size in bytes.
    A :class:`Stacked` member is streamed from its chunks, an array of numbers in blocks of rows; any other value
    is written as ``np.asarray``."""
    path = Path(path)
    with atomic_file(path) as f, zipfile.ZipFile(f, "w", compression=zipfile.ZIP_STORED, allowZip64=True) as zf:
        for name, value in arrays.items():
            if isinstance(value, np.ndarray) and value.ndim >= 1 and value.dtype.kind in "biufc":
                value = _blocks(value)
            with zf.open(name + ".npy", "w", force_zip64=True) as member:
                if isinstance(value, Stacked):
                    header = {"descr": npformat.dtype_to_descr(np.dtype(value.dtype)), "fortran_order": False,
                              "shape": tuple(value.shape)}
                    npformat.write_array_header_2_0(member, header)
                    written = 0
                    for chunk in value.chunks:
                        data = np.ascontiguousarray(chunk, dtype=value.dtype)
                        member.write(memoryview(data.reshape(-1).view(np.uint8)))  # (its bytes, not a copy)
                        written += data.size
                    if written != int(np.prod(value.shape)):
                        raise ValueError(f"{name}: {written} numbers written for a shape {value.shape}")
                else:
                    npformat.write_array(member, np.asarray(value), allow_pickle=False)
    return path.stat().st_size


def read_member(path: Path, name: str) -> np.ndarray:
    with npz.open_npz(path) as archive:
        return archive.read(name)


def member_shapes(path: Path) -> dict[str, tuple[tuple, np.dtype]]:
    """Every member's (shape, dtype), read from the .npy headers only (no array is loaded)."""
    return npz.shapes(path)


def read_npz(path: Path) -> dict[str, np.ndarray]:
    return npz.load(path)
