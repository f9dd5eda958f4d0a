"""Batches over threads with a deadline (dynamics.parallel): same numbers as without one, and a deadline that
has passed stops the work with DeadlineExceeded instead of finishing it."""

import time

import numpy as np
import pytest

import dynamics
from dynamics import _core, parallel

from robots import chain_urdf


def test_a_generous_deadline_changes_no_number():
    model = dynamics.load_urdf(chain_urdf(12))
    rng = np.random.default_rng(0)
    Q = rng.uniform(-1, 1, (3000, model.nq))
    V = rng.uniform(-1, 1, (3000, model.nv))
    free = dynamics.inverse_dynamics(model, Q, V, V)
    with parallel.deadline(time.monotonic() + 60):
        bounded = dynamics.inverse_dynamics(model, Q, V, V)
        M = dynamics.mass_matrix(model, Q[:100])
    np.testing.assert_array_equal(bounded, free)
    np.testing.assert_array_equal(M, dynamics.mass_matrix(model, Q[:100]))


@pytest.mark.parametrize("n", [10, 5000])
def test_a_passed_deadline_stops_the_batch(n):
    model = dynamics.load_urdf(chain_urdf(12))
    Q = np.zeros((n, model.nq))
    with parallel.deadline(time.monotonic() - 1.0), pytest.raises(dynamics.DeadlineExceeded) as err:
        dynamics.forward_dynamics(model, Q, Q[:, :model.nv], Q[:, :model.nv])
    assert err.value.total == n and err.value.done == 0
    assert not isinstance(err.value, ValueError)  # not an input error


def test_the_deadline_is_per_context_and_restored():
    model = dynamics.load_urdf(chain_urdf(4))
    with parallel.deadline(time.monotonic() - 1.0):
        with parallel.deadline(None):
            dynamics.mass_matrix(model, np.zeros((3, model.nq)))
    dynamics.mass_matrix(model, np.zeros((3, model.nq)))


def test_the_first_singular_state_is_reported_whichever_thread_meets_it():
    """Threads take states in chunks from one counter (core/parallel.hpp); with every state singular each thread
    stops at its first, and the status still names state 0 of the batch, as the public error does."""
    text = chain_urdf(2)  # the last link carries nothing: M is singular at joint1 in every state
    head, tail = text.rsplit('<link name="link1">', 1)
    model = dynamics.load_urdf(head + '<link name="link1"/>' + tail.split("</link>", 1)[1])
    B = 5000
    Q = np.random.default_rng(0).uniform(-1, 1, (B, 2))
    out = np.empty((B, 2))
    done, expired, failed, _ = _core.aba_batch(model.core, Q, Q, Q, np.zeros((1, 0, 6)), np.array(model.gravity),
                                               True, out, 2, float("inf"))
    assert (failed, expired, done) == (0, False, 0)
    with pytest.raises(dynamics.InputError, match="singular at joint 'joint1'"):
        dynamics.forward_dynamics(model, Q, Q, Q)
