"""The single-state fast path (one compiled call that checks its inputs itself, on the packed model) against the
general path: the same numbers bit for bit, and every bad input the same clear error."""

import pickle
import re
import threading

import numpy as np
import pytest

import dynamics
from dynamics import _core
from robots import chain_urdf, erd, random_state, random_urdf

ROBOTS = {
    "panda": (erd("panda_description/urdf/panda.urdf"), False),
    "ur5": (erd("ur_description/urdf/ur5_robot.urdf"), False),
    "talos": (erd("talos_data/robots/talos_reduced.urdf"), True),
    "random-floating": (random_urdf(np.random.default_rng(3), 9, floating_joint=True), False),
}

# name -> (function, which of (q, v, a/tau) it takes)
FUNCTIONS = {
    "inverse_dynamics": (dynamics.inverse_dynamics, 3),
    "forward_dynamics": (dynamics.forward_dynamics, 3),
    "mass_matrix": (dynamics.mass_matrix, 1),
    "gravity_torques": (dynamics.gravity_torques, 1),
    "bias_forces": (dynamics.bias_forces, 2),
}


@pytest.fixture(scope="module", params=list(ROBOTS))
def model(request):
    source, floating = ROBOTS[request.param]
    return dynamics.load_urdf(source, floating_base=floating)


def _states(model, seed=0):
    rng = np.random.default_rng(seed)
    q, v, a = random_state(model, rng)
    zero = np.zeros(model.nv)
    return [(q, v, a), (q, zero, a), (q, v, zero), (q, zero, zero)]  # zero terms are skipped on both paths


@pytest.mark.parametrize("name", list(FUNCTIONS))
def test_fast_path_equals_batched_and_general_bit_for_bit(model, name):
    f, n = FUNCTIONS[name]
    for state in _states(model):
        args = state[:n]
        fast = f(model, *args)
        batched = f(model, *(np.stack([x, x]) for x in args))
        general = f(model, *(list(x) for x in args))  # lists: the general path for one state
        assert fast.shape == general.shape == batched.shape[1:]
        np.testing.assert_array_equal(fast, batched[0])
        np.testing.assert_array_equal(fast, batched[1])
        np.testing.assert_array_equal(fast, general)


def test_fast_path_is_independent_of_layout_and_writeability(model):
    """Strided, read-only and integer inputs are not the fast path's: they take the general path, same answer."""
    q, v, a = _states(model)[0]
    tau = dynamics.inverse_dynamics(model, q, v, a)
    strided = np.empty((model.nq, 2))
    strided[:, 0] = q
    frozen = q.copy()
    frozen.flags.writeable = False
    np.testing.assert_array_equal(dynamics.inverse_dynamics(model, strided[:, 0], v, a), tau)
    np.testing.assert_array_equal(dynamics.inverse_dynamics(model, frozen, v, a), tau)
    qi = np.round(q).astype(np.int64)
    np.testing.assert_array_equal(dynamics.mass_matrix(model, qi), dynamics.mass_matrix(model, qi.astype(float)))
    np.testing.assert_array_equal(dynamics.gravity_torques(model, q.astype(np.float32)),
                                  dynamics.gravity_torques(model, q.astype(np.float32).astype(float)))


def _call(f, n, model, q, v, a):
    return f(model, *(q, v, a)[:n])


def _bad_inputs(model):
    """(what, q, v, a, expected message) for one state of float64 vectors: the fast path's own inputs."""
    q, v, a = _states(model)[0]
    out = []
    for k, (arg, x) in enumerate(zip("qva", (q, v, a))):
        nan, inf, short = x.copy(), x.copy(), x[:-1].copy()
        nan[0], inf[-1] = np.nan, -np.inf
        for what, bad, msg in ((f"nan in {arg}", nan, "contains non-finite values"),
                               (f"inf in {arg}", inf, "contains non-finite values"),
                               (f"short {arg}", short, r"expected shape \(")):
            args = [q, v, a]
            args[k] = bad
            out.append((k, what, *args, msg))
    return out


@pytest.mark.parametrize("name", list(FUNCTIONS))
def test_every_bad_input_gets_the_general_paths_error(model, name):
    f, n = FUNCTIONS[name]
    arg_names = ("q", "v", "tau" if name == "forward_dynamics" else "a")
    for k, what, q, v, a, msg in _bad_inputs(model):
        if k >= n:
            continue
        with pytest.raises(dynamics.InputError) as fast:
            _call(f, n, model, q, v, a)
        with pytest.raises(dynamics.InputError) as general:  # lists never take the fast path
            _call(f, n, model, list(q), list(v), list(a))
        assert str(fast.value) == str(general.value), what
        assert str(fast.value).startswith(arg_names[k] + ": "), (what, str(fast.value))
        assert re.search(msg, str(fast.value)), (what, str(fast.value))


def test_zero_quaternion_and_non_model_errors_are_unchanged():
    talos = dynamics.load_urdf(*ROBOTS["talos"][:1], floating_base=True)
    q = talos.neutral()
    q[3:7] = 0.0
    v = np.zeros(talos.nv)
    for f, args in ((dynamics.inverse_dynamics, (q, v, v)), (dynamics.forward_dynamics, (q, v, v)),
                    (dynamics.mass_matrix, (q,)), (dynamics.gravity_torques, (q,)), (dynamics.bias_forces, (q, v))):
        with pytest.raises(dynamics.InputError, match=r"q: the quaternion q\[3:7\] of a floating joint is zero"):
            f(talos, *args)
    with pytest.raises(dynamics.InputError, match="model: expected a dynamics.Model"):
        dynamics.inverse_dynamics("panda", np.zeros(3), np.zeros(3), np.zeros(3))
    with pytest.raises(dynamics.InputError, match="model: expected a dynamics.Model"):
        dynamics.mass_matrix(None, np.zeros(3))


def test_singular_joint_is_named_on_the_fast_path():
    text = chain_urdf(2)  # the last link carries nothing: M is singular at joint1
    head, tail = text.rsplit('<link name="link1">', 1)
    model = dynamics.load_urdf(head + '<link name="link1"/>' + tail.split("</link>", 1)[1])
    with pytest.raises(dynamics.InputError, match="singular at joint 'joint1'"):
        dynamics.forward_dynamics(model, np.array([0.1, 0.2]), np.zeros(2), np.zeros(2))


def test_wrong_rank_never_reaches_the_compiled_call():
    """A (1, n) row or a 0-d array is not a state vector: the general path answers (a batch of one) or refuses."""
    model = dynamics.load_urdf(chain_urdf(3))
    q = np.array([[0.1, 0.2, 0.3]])
    assert dynamics.mass_matrix(model, q).shape == (1, 3, 3)
    with pytest.raises(dynamics.InputError, match=r"q: expected shape \(3,\) or \(B, 3\), got \(\)"):
        dynamics.gravity_torques(model, np.float64(0.1))


def test_concurrent_single_calls_agree():
    """Each compiled call keeps its scratch on its own stack: threads never share it."""
    model = dynamics.load_urdf(ROBOTS["panda"][0])
    states = [random_state(model, np.random.default_rng(k)) for k in range(8)]
    expected = [dynamics.forward_dynamics(model, q, v, a) for q, v, a in states]
    errors = []

    def work():
        for _ in range(200):
            for (q, v, a), ref in zip(states, expected):
                if not np.array_equal(dynamics.forward_dynamics(model, q, v, a), ref):
                    errors.append(1)

    threads = [threading.Thread(target=work) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors


def test_model_survives_pickling():
    """A model from a process pool or a Ray task builds its core model again: the same numbers, on the fast path."""
    model = dynamics.load_urdf(ROBOTS["ur5"][0])
    clone = pickle.loads(pickle.dumps(model))
    assert not clone.tree.S.flags.writeable and clone.core is not model.core
    q, v, a = _states(model)[0]
    fast = _core.rnea(clone.core, q, v, a)
    assert fast is not None
    np.testing.assert_array_equal(fast, dynamics.inverse_dynamics(model, q, v, a))


def test_states_that_came_by_pickle_take_the_fast_path():
    """An array unpickled (from a process pool or a Ray task) has a dtype object of its own: the entries compare
    the type number and byte order, so it is still taken by the single call, bit for bit."""
    model = dynamics.load_urdf(ROBOTS["ur5"][0])
    q, v, a = pickle.loads(pickle.dumps(_states(model)[0]))
    assert q.dtype is not np.dtype(np.float64)
    tau = _core.rnea(model.core, q, v, a)
    np.testing.assert_array_equal(tau, dynamics.inverse_dynamics(model, q.copy(), v.copy(), a.copy()))
    assert _core.placements(model.core, q) is not None
    swapped = q.astype(">f8")  # the same type number in the other byte order: not the single call's to read
    assert _core.rnea(model.core, swapped, v, a) is None


class _Subclass(np.ndarray):
    pass


def _unusual_arrays(x):
    """x as arrays the compiled entries do not take themselves (they read numpy's array header), or take although
    the old compiled entry points did not (read-only): each must get the general path's result."""
    strided = np.empty(2 * len(x))
    strided[::2] = x
    readonly = x.copy()
    readonly.flags.writeable = False
    return {"float32": x.astype(np.float32), "big-endian": x.astype(">f8"), "strided": strided[::2],
            "reversed": x[::-1].copy()[::-1], "subclass": x.copy().view(_Subclass), "read-only": readonly,
            "int": np.round(x).astype(np.int64)}


@pytest.mark.parametrize("name", list(FUNCTIONS))
def test_unusual_arrays_get_the_general_paths_result(model, name):
    f, n = FUNCTIONS[name]
    state = _states(model)[0][:n]
    for k in range(n):
        for label, x in _unusual_arrays(state[k]).items():
            args = list(state)
            args[k] = x
            general = [[float(y) for y in arg] for arg in args]
            np.testing.assert_array_equal(f(model, *args), f(model, *general), err_msg=f"{label} argument {k}")


def test_core_entries_refuse_what_they_do_not_take(model):
    """The single-call entries, called directly (as the public functions do), answer None (the general path's
    turn), never crash, for anything but exact float64 states of the right length: a non-array, another dtype,
    rank or length, non-finite values; a wrong arity or a model that is not the core's is a TypeError."""
    q, v, a = _states(model)[0]
    c = model.core
    entries = [(_core.rnea, (q, v, a)), (_core.aba, (q, v, a)), (_core.bias_forces, (q, v)),
               (_core.gravity_torques, (q,)), (_core.crba, (q,)), (_core.inverse_mass_matrix, (q,)),
               (_core.placements, (q,)), (lambda c, q: _core.center_of_mass(c, q, True), (q,)),
               (lambda c, q: _core.frame_jacobian(c, q, 0, 0), (q,))]
    for call, states in entries:
        assert call(c, *states) is not None
        for k in range(len(states)):
            nan = states[k].copy()
            nan[-1] = np.nan
            for bad in (None, 1.0, "q", list(states[k]), states[k].astype(np.float32), states[k][None],
                        states[k][:-1].copy(), np.append(states[k], 0.0), nan, np.empty(2 * len(states[k]))[::2]):
                args = list(states)
                args[k] = bad
                assert call(c, *args) is None, (call, k, bad)
    for bad_model in (None, model, q, "model"):
        with pytest.raises(TypeError):
            _core.rnea(bad_model, q, v, a)
    with pytest.raises(TypeError):
        _core.rnea(c, q, v)  # one argument short
    assert _core.frame_jacobian(c, q, len(model.frame_names), 0) is None  # a frame or reference out of range
    assert _core.frame_jacobian(c, q, -1, 0) is None and _core.frame_jacobian(c, q, 0, 3) is None


def test_constrained_entry_refuses_what_it_does_not_take():
    """forward_dynamics on a constrained model (Panda's mimic fingers) goes through the core's constrained entry:
    None for anything else, and its a is the general path's."""
    from dynamics.constraints import core_constraints
    model = dynamics.load_urdf(ROBOTS["panda"][0])
    assert model.constraints
    q, v, tau = _states(model)[0]
    c, con, nv = model.core, core_constraints(model), model.nv
    a, lam = _core.constrained_forward_dynamics(c, con, q, v, tau, 0.0, 0.0)
    np.testing.assert_array_equal(a, dynamics.forward_dynamics(model, list(q), list(v), list(tau)))
    np.testing.assert_array_equal(lam, dynamics.constrained_forward_dynamics(model, list(q), v, tau)[1])
    for args in [(q, v, tau.astype(np.float32)), (q[None], v, tau), (q, v[:-1], tau), (q, np.empty(2 * nv)[::2], tau),
                 ("q", v, tau), (None, v, tau)]:
        assert _core.constrained_forward_dynamics(c, con, *args, 0.0, 0.0) is None
    for args in [(q, v, tau, 0.0), (q, v, tau, 0.0, 0.0, 0.0)]:
        with pytest.raises(TypeError):
            _core.constrained_forward_dynamics(c, con, *args)
