"""Jobs see robots as their key does (issue 11 section 3 with issue 12): a job on another key's robot is refused
404 at submission, as for a robot that does not exist; a robot is reachable by the name it was uploaded with."""

from __future__ import annotations

import numpy as np

from service_fixtures import ROBOTS, in_process_app


def _headers(key):
    return {"Authorization": f"Bearer {key}"}


def test_a_job_reaches_only_its_keys_robots_and_names_resolve(tmp_path):
    urdf = (ROBOTS / "planar_2r.urdf").read_text()
    with in_process_app(tmp_path, api_keys=("k1", "k2"), job_workers=1) as c:
        up = c.post("/v1/robots", json={"urdf": urdf, "name": "mine"}, headers=_headers("k1"))
        assert up.status_code == 201, up.text
        rid = up.json()["id"]
        job = {"kind": "inverse_dynamics", "inputs": {"q": np.zeros((3, 2)).tolist(), "v": np.zeros((3, 2)).tolist(),
                                                      "a": np.zeros((3, 2)).tolist()}}
        for ref in (rid, "mine"):
            r = c.post("/v1/jobs", json={"robot": ref, **job}, headers=_headers("k2"))
            assert r.status_code == 404 and r.json()["field"] == "robot", r.text
        r = c.post("/v1/jobs", json={"robot": "mine", **job}, headers=_headers("k1"))
        assert r.status_code == 202, r.text
        assert r.json()["robot"] == rid
        assert c.get(r.json()["status_url"], headers=_headers("k2")).status_code == 404
