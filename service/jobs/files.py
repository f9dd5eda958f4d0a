"""Where a job's arrays live, beside the database, and how they are written so that a crash never leaves half.

    <store>/jobs/jobs.db                the records (service.jobs.db)
    <store>/jobs/inputs/<id>.npz        the inputs, written before the job is queued
    <store>/jobs/parts/<id>/<lo>-<hi>.npz   results of the items [lo, hi) done so far (a restart resumes after them)
    <store>/jobs/results/<id>.npz       the result, once done
    <store>/jobs/boots/<boot>.lock      held (flock) by the server process whose jobs run under that boot

Every .npz is written to a temporary name in the same directory, flushed and fsync'ed, renamed over its final
name and the directory fsync'ed (:func:`write_npz`): after a crash a file is wholly there or not at all.
Archives are plain ``np.savez`` (no pickles: read back with ``allow_pickle=False``); a non-array member (a
report) is a 0-d string array holding JSON, as in the service's .npz answers.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

import numpy as np


@dataclass(frozen=True)
class JobFiles:
    root: Path  # <store>/jobs

    @classmethod
    def under(cls, store_dir: Path) -> "JobFiles":
        files = cls(Path(store_dir).resolve() / "jobs")
        for sub in ("inputs", "parts", "results", "boots"):
            (files.root / sub).mkdir(parents=True, exist_ok=True)
        return files

    @property
    def db(self) -> Path:
        return self.root / "jobs.db"

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


def fsync_dir(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def write_npz(path: Path, arrays: Mapping[str, Any]) -> int:
    """``np.savez`` to ``path`` atomically and durably; returns the file's size in bytes."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix="." + path.name + ".", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            np.savez(f, **arrays)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise
    fsync_dir(path.parent)
    return path.stat().st_size


def read_npz(path: Path) -> dict[str, np.ndarray]:
    with np.load(path, allow_pickle=False) as npz:
        return {name: npz[name] for name in npz.files}
