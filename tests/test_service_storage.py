"""A full disk (issue 25 A4): uploads and job submissions answer 507 naming the storage, leave no file behind, and a
job that fills the disk while it runs fails with that reason. In-process: the disk is made full by an ``fsync``
that fails as it does on a full ext4 (ENOSPC), the error a write past the end of a full disk reports."""

from __future__ import annotations

import errno
import os


from service import store as store_module
from service.jobs import runner
from service.jobs.db import JobDB
from service.jobs.files import JobFiles
from service.jobs.manager import Jobs
from service.models import Models
from service.settings import Settings
from service.store import RobotStore
from service_fixtures import ROBOTS, in_process_app

URDF = (ROBOTS / "pendulum.urdf").read_text()


def no_space(fd):
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


def files_under(path):
    """The stored files (not the lock or the job database)."""
    return sorted(p.relative_to(path) for p in path.rglob("*") if p.is_file() and p.suffix != ".lock"
                  and p.name != "jobs.db" and not p.name.startswith("jobs.db-"))


def test_a_full_disk_answers_507_naming_the_storage(tmp_path, monkeypatch):
    with in_process_app(tmp_path / "store") as client:
        before = files_under(tmp_path / "store")
        monkeypatch.setattr(store_module.os, "fsync", no_space)
        r = client.post("/v1/robots", json={"name": "p", "urdf": URDF})
        assert r.status_code == 507, r.text
        body = r.json()
        assert body["code"] == "insufficient_storage" and body["field"] == "storage"
        assert "the robot store" in body["detail"] and str(tmp_path / "store") in body["detail"]
        assert "No space left on device" in body["detail"]
        r = client.post("/v1/jobs", json={"robot": "planar_2r", "kind": "mass_matrix", "inputs": {"q": [[0, 0]]}})
        assert r.status_code == 507, r.text
        assert "the job store" in r.json()["detail"]
        assert files_under(tmp_path / "store") == before  # nothing left by either
        monkeypatch.undo()
        assert client.post("/v1/robots", json={"name": "p", "urdf": URDF}).status_code == 201


def test_a_job_that_fills_the_disk_fails_with_that_reason(tmp_path, monkeypatch):
    settings = Settings(store_dir=tmp_path, robots_dir=ROBOTS, job_workers=0)
    store = RobotStore(settings.store_dir, settings.robots_dir)
    jobs = Jobs(settings, Models(store, 4))
    status = jobs.submit(None, b'{"robot": "planar_2r", "kind": "mass_matrix", "inputs": {"q": [[0, 0], [1, 1]]}}',
                         "application/json")
    files = JobFiles.under(tmp_path)
    db = JobDB(files.db)
    claimed = db.claim("boot-1")
    assert claimed.id == status["id"]
    monkeypatch.setattr(store_module.os, "fsync", no_space)
    monkeypatch.setattr(runner, "_process", {})
    monkeypatch.setenv("DYNAMICS_STORE", str(tmp_path))
    monkeypatch.setenv("DYNAMICS_ROBOTS_DIR", str(ROBOTS))
    runner.run_job(files, claimed.id, "boot-1")
    failed = db.get(claimed.id)
    assert failed.status == "failed" and "the job store" in failed.error and "No space left" in failed.error
    assert not files.inputs(claimed.id).exists() and not files.parts(claimed.id).exists()
    jobs.close()


def test_a_submit_that_fails_after_writing_its_inputs_leaves_no_file(tmp_path, monkeypatch):
    """Issue 25 A1: a submit whose database insert failed (an array in the spec's JSON) left its inputs .npz, which
    no quota counted and no housekeeping removed. Whatever fails after the write, the file goes."""
    settings = Settings(store_dir=tmp_path, robots_dir=ROBOTS, job_workers=0)
    jobs = Jobs(settings, Models(RobotStore(settings.store_dir, settings.robots_dir), 4))

    def broken(*args, **kwargs):
        raise TypeError("Object of type ndarray is not JSON serializable")

    monkeypatch.setattr(jobs.db, "create", broken)
    try:
        jobs.submit(None, b'{"robot": "planar_2r", "kind": "mass_matrix", "inputs": {"q": [[0, 0]]}}',
                    "application/json")
    except TypeError:
        pass
    else:
        raise AssertionError("the failure was swallowed")
    assert list((tmp_path / "jobs" / "inputs").iterdir()) == []
    jobs.close()
