"""The simulation's numbers do not depend on how its compiled code is put together (issue 24's proof): the
cases of tests/sim_golden.py (the stiff suite, the four-bar, the Panda PD run, one run per compiled torque kind)
give bit for bit the samples and report numbers recorded on the code before the change (tests/data/
sim_golden.json, digests written by ``python -m tests.sim_golden`` on that code)."""

import json

import pytest

from sim_golden import GOLDEN, cases, digest, numbers

with open(GOLDEN) as f:
    RECORDED = json.load(f)


@pytest.mark.parametrize("name", sorted(RECORDED))
def test_bit_identical_to_recorded(name):
    got = {key: digest(value) for key, value in numbers(cases()[name]()).items()}
    assert set(got) == set(RECORDED[name])
    for key, d in got.items():
        want = RECORDED[name][key]
        assert d == want, f"{name}: {key} differs (last row {d['last']} against {want['last']})"
