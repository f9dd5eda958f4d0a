"""The simulation's numbers do not depend on how its compiled code is put together (issue 24's proof): the
cases of tests/sim_golden.py (the stiff suite, the four-bar, the Panda PD run, one run per compiled torque kind)
give bit for bit the samples and report numbers recorded on the code before the change (tests/data/
sim_golden.json, digests written by ``python -m tests.sim_golden`` on that code).

Bit for bit on a machine whose math library rounds as the recording machine's (the recorded
``arithmetic_signature``); elsewhere (another processor's libm variant moves a step size by an ulp) the last row
of every array within 1e-10 relative and the report's counts exactly."""

import json

import numpy as np
import pytest

from sim_golden import GOLDEN, arithmetic_signature, cases, digest, numbers

with open(GOLDEN) as f:
    RECORDED = json.load(f)
ARITHMETIC = RECORDED.pop("_arithmetic", None)
#: the report's entries that are counts (sim_golden.REPORT_KEYS: steps, rejected_steps, rhs_evals, jacobian_evals,
#: lu_decompositions)
COUNTS = slice(1, 6)


@pytest.fixture(scope="module")
def same_arithmetic():
    return ARITHMETIC == arithmetic_signature()


@pytest.mark.parametrize("name", sorted(RECORDED))
def test_bit_identical_to_recorded(name, same_arithmetic):
    got = {key: digest(value) for key, value in numbers(cases()[name]()).items()}
    assert set(got) == set(RECORDED[name])
    for key, d in got.items():
        want = RECORDED[name][key]
        if same_arithmetic:
            # (shape and hash: the last row is for the message, and NaN != NaN in a list)
            assert (d["shape"], d["sha256"]) == (want["shape"], want["sha256"]), \
                f"{name}: {key} differs (last row {d['last']} against {want['last']})"
            continue
        assert d["shape"] == want["shape"], f"{name}: {key} has shape {d['shape']}, recorded {want['shape']}"
        last, rec = np.array(d["last"]), np.array(want["last"])
        if key == "report":
            assert np.array_equal(last[COUNTS], rec[COUNTS]), f"{name}: report counts {last} against {rec}"
        ok = np.isclose(last, rec, rtol=1e-10, atol=1e-13) | (np.isnan(last) & np.isnan(rec))
        assert ok.all(), f"{name}: {key} differs beyond round-off (last row {d['last']} against {want['last']})"
