"""Schemathesis over every operation of the OpenAPI document, against a real server, with a bounded budget.

Issue 11 section 4: no 5xx, and every answer conforms to the document (status codes, content types, bodies,
headers). Data the schema allows but a robot refuses for its own reasons (a state of the wrong size for
that robot) is a documented 422, so ``positive_data_acceptance`` is left out; so are the checks that need
an API key (this server runs without keys).
"""

from __future__ import annotations

from collections import Counter

import httpx
import pytest
import schemathesis
from hypothesis import HealthCheck, given, settings
from schemathesis.checks import not_a_server_error
from schemathesis.specs.openapi.checks import (content_type_conformance, response_headers_conformance,
                                               response_schema_conformance, status_code_conformance)

from service_fixtures import shared_server

EXAMPLES = 25  # per operation: ~14 operations x 25 requests, well under a minute


#: a job body the server accepts: the job routes are reached beyond their 422s and 404s (issue 25)
JOB = {"robot": "planar_2r", "kind": "mass_matrix", "inputs": {"q": [[0.1, 0.2], [0.3, 0.4]]}}


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    return shared_server(tmp_path_factory.getbasetemp())


@pytest.fixture(scope="module")
def api_schema(server):
    return schemathesis.openapi.from_url(server.url + "/openapi.json")


CHECKS = [not_a_server_error, status_code_conformance, content_type_conformance, response_schema_conformance,
          response_headers_conformance]


def test_every_operation(api_schema, server):
    """Each operation in turn (schemathesis' pytest plugin does not run under this pytest), every failure listed;
    the jobs' routes too, some of their requests about a real job."""
    failures, operations, statuses, labels = [], 0, Counter(), []
    job_id = httpx.post(server.url + "/v1/jobs", json=JOB).json()["id"]
    for result in api_schema.get_all_operations():
        operation = result.ok()
        operations += 1
        labels.append(operation.label)

        @given(case=operation.as_strategy())
        @settings(max_examples=EXAMPLES, deadline=None, derandomize=True, database=None,
                  suppress_health_check=list(HealthCheck))
        def run(case):
            if case.path_parameters and "robot_id" in case.path_parameters and len(statuses) % 4:
                case.path_parameters["robot_id"] = "planar_2r"  # (a random id is only a 404: a known one mostly)
            if case.path_parameters and "job_id" in case.path_parameters and len(statuses) % 2:
                case.path_parameters["job_id"] = job_id
            if operation.label == "POST /v1/jobs" and len(statuses) % 3 == 0:
                case.body = JOB
            statuses[case.call_and_validate(checks=CHECKS, timeout=30).status_code] += 1

        try:
            run()
        except Exception as e:  # (a FailureGroup: what failed and the request to replay it)
            failures.append(f"{operation.label}: {str(e)[:1500]}")
    assert operations >= 10 and sum(statuses.values()) >= 5 * operations, statuses
    assert {"POST /v1/jobs", "GET /v1/jobs/{job_id}", "GET /v1/jobs/{job_id}/result",
            "DELETE /v1/jobs/{job_id}"} <= set(labels), labels
    assert statuses[202] > 0, statuses  # jobs were accepted
    print("schemathesis:", operations, "operations, answers by status:", dict(statuses))
    assert not failures, "\n\n".join(failures)
