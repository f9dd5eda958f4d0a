"""The kinematics single-state fast path (forward_kinematics, frame_jacobian, center_of_mass, com_jacobian,
inverse_mass_matrix: one compiled call that checks q, the frame index and the reference itself) against the
batched and general paths: the same numbers bit for bit, and every bad input the same clear error."""

import re

import numpy as np
import pytest

import dynamics
from robots import erd, random_state, random_urdf

ROBOTS = {
    "panda": (erd("panda_description/urdf/panda.urdf"), False),
    "talos": (erd("talos_data/robots/talos_reduced.urdf"), True),
    "random-floating": (random_urdf(np.random.default_rng(5), 8, floating_joint=True), False),
}
REFERENCES = ("local_world_aligned", "local", "world")


@pytest.fixture(scope="module", params=list(ROBOTS))
def model(request):
    source, floating = ROBOTS[request.param]
    return dynamics.load_urdf(source, floating_base=floating)


def _q(model, seed=0):
    return random_state(model, np.random.default_rng(seed))[0]


def _frames(model):
    """The last frame (deepest support), one in the middle, and the first (the root's or the world's)."""
    names = model.frame_names
    return [names[-1], names[len(names) // 2], names[0]]


@pytest.mark.parametrize("name", ["forward_kinematics", "center_of_mass", "com_jacobian", "inverse_mass_matrix"])
def test_fast_path_equals_batched_and_general_bit_for_bit(model, name):
    f = getattr(dynamics, name)
    for seed in range(3):
        q = _q(model, seed)
        fast, batched, general = f(model, q), f(model, np.stack([q, q])), f(model, list(q))
        assert fast.shape == general.shape == batched.shape[1:]
        np.testing.assert_array_equal(fast, batched[0])
        np.testing.assert_array_equal(fast, batched[1])
        np.testing.assert_array_equal(fast, general)


def test_frame_jacobian_fast_path_bit_for_bit_by_name_and_index(model):
    q = _q(model)
    for frame in _frames(model):
        k = model.frame_index(frame)
        for ref in REFERENCES:
            fast = dynamics.frame_jacobian(model, q, frame, reference=ref)
            np.testing.assert_array_equal(dynamics.frame_jacobian(model, q, k, reference=ref), fast)
            np.testing.assert_array_equal(dynamics.frame_jacobian(model, q, np.int64(k), reference=ref), fast)
            np.testing.assert_array_equal(dynamics.frame_jacobian(model, list(q), frame, reference=ref), fast)
            np.testing.assert_array_equal(dynamics.frame_jacobian(model, np.stack([q, q]), frame, reference=ref)[1],
                                          fast)
            # a point at the origin takes the general path: the same numbers
            np.testing.assert_array_equal(dynamics.frame_jacobian(model, q, frame, reference=ref, point=np.zeros(3)),
                                          fast)
            # columns off the frame's support are zero (the fast path clears J itself)
            general = dynamics.frame_jacobian(model, list(q), frame, reference=ref)
            assert np.array_equal(fast == 0.0, general == 0.0)


def test_placements_agree_with_frame_placement(model):
    """_frame_pose by frame kind (built with the model) gives the same placements on the all-frames and one-frame
    paths."""
    q = _q(model, 1)
    T = dynamics.forward_kinematics(model, q)
    for frame in _frames(model):
        np.testing.assert_array_equal(dynamics.frame_placement(model, q, frame), T[model.frame_index(frame)])


def _same_error(f, *args, match, **kwargs):
    with pytest.raises(dynamics.InputError) as fast:
        f(*args, **kwargs)
    model, q, *rest = args
    with pytest.raises(dynamics.InputError) as general:  # a list q never takes the fast path
        f(model, list(q), *rest, **kwargs)
    assert str(fast.value) == str(general.value)
    assert re.search(match, str(fast.value)), str(fast.value)


def test_bad_frames_and_references_get_the_general_paths_error(model):
    q = _q(model)
    frame = model.frame_names[-1]
    nf = len(model.frame_names)
    J = dynamics.frame_jacobian
    _same_error(J, model, q, frame + "x", match=re.escape(frame))  # the closest names are listed
    _same_error(J, model, q, "no such frame", match="frame")
    _same_error(J, model, q, nf, match=rf"frame: index {nf} out of range \[0, {nf}\)")
    _same_error(J, model, q, -1, match=r"frame: index -1 out of range")
    _same_error(J, model, q, True, match="frame: expected a frame name \\(str\\) or index \\(int\\), got bool")
    _same_error(J, model, q, 1.0, match="got float")
    _same_error(J, model, q, [frame], match="got list")
    _same_error(J, model, q, frame, reference="body", match=r"reference: expected one of \['world', 'local', ")
    _same_error(J, model, q, frame, reference=["world"], match="reference: expected one of")
    _same_error(J, model, q, frame, reference=None, match="reference: expected one of")


@pytest.mark.parametrize("name", ["forward_kinematics", "frame_jacobian", "center_of_mass", "com_jacobian",
                                  "inverse_mass_matrix"])
def test_bad_configurations_get_the_general_paths_error(model, name):
    f = getattr(dynamics, name)
    extra = (model.frame_names[-1],) if name == "frame_jacobian" else ()
    q = _q(model)
    nan, inf, short, long = q.copy(), q.copy(), q[:-1].copy(), np.append(q, 0.0)
    nan[0], inf[-1] = np.nan, np.inf
    for bad, match in ((nan, "q: .*non-finite"), (inf, "q: .*non-finite"), (short, r"q: expected shape \("),
                       (long, r"q: expected shape \(")):
        _same_error(f, model, bad, *extra, match=match)
    if model.floating_base:
        zero = q.copy()
        zero[3:7] = 0.0
        _same_error(f, model, zero, *extra, match=r"q: the quaternion q\[3:7\] of a floating joint is zero")


def test_non_model_is_refused():
    with pytest.raises(dynamics.InputError, match="model: expected a dynamics.Model"):
        dynamics.frame_jacobian("panda", np.zeros(9), "panda_hand")
    with pytest.raises(dynamics.InputError, match="model: expected a dynamics.Model"):
        dynamics.forward_kinematics(None, np.zeros(9))


class _Subclass(np.ndarray):
    pass


def _unusual_arrays(q):
    """q as arrays the compiled entry does not take itself (it reads numpy's array header): each must get the
    general path's result."""
    strided = np.empty(2 * len(q))
    strided[::2] = q
    readonly = q.copy()
    readonly.flags.writeable = False
    return {"float32": q.astype(np.float32), "big-endian": q.astype(">f8"), "strided": strided[::2],
            "reversed": q[::-1].copy()[::-1], "subclass": q.copy().view(_Subclass), "read-only": readonly,
            "int": np.round(q).astype(np.int64)}


@pytest.mark.parametrize("name", ["forward_kinematics", "frame_jacobian"])
def test_unusual_arrays_get_the_general_paths_result(model, name):
    f = getattr(dynamics, name)
    extra = (model.frame_names[-1],) if name == "frame_jacobian" else ()
    for label, x in _unusual_arrays(_q(model)).items():
        np.testing.assert_array_equal(f(model, x, *extra), f(model, [float(v) for v in x], *extra), err_msg=label)


def test_core_entries_refuse_what_they_do_not_take(model):
    """The single-call entries called directly (as the public functions do) answer None, never crash, for
    anything but an exact float64 configuration, a frame index in range and a known reference code."""
    from dynamics import _core
    q, c = _q(model), model.core
    assert _core.placements(c, q) is not None and _core.frame_jacobian(c, q, 0, 2) is not None
    for bad in (q.astype(np.float32), q[None], "q", 1.0, None, q[:-1].copy(), np.repeat(q, 2)[::2]):
        assert _core.placements(c, bad) is None and _core.frame_jacobian(c, bad, 0, 2) is None
    for f, ref in ((len(model.frames), 2), (0, 3), (-1, 2), (0, -1)):
        assert _core.frame_jacobian(c, q, f, ref) is None
    for args in [(), (c, q, 0), (None, q, 0, 2), (q, q, 0, 2), (c, q, 0, None), (c, q, "0", 2)]:
        with pytest.raises(TypeError):
            _core.frame_jacobian(*args)
