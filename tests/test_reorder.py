"""A vector in Pinocchio's joint order and conventions, mapped into ours with dynamics.reorder, gives
Pinocchio's numbers (Talos branches differently; continuous joints are (cos, sin) pairs there)."""

import numpy as np
import pinocchio as pin
import pytest

import dynamics
from robots import erd, random_urdf


def pin_names(pm):
    return [pm.names[j] for j in range(1, pm.njoints)]


def test_talos_q_copied_from_pinocchio():
    path = erd("talos_data/robots/talos_reduced.urdf")
    model = dynamics.load_urdf(path, floating_base=True, strict_inertia=False)
    pm = pin.buildModelFromUrdf(path, pin.JointModelFreeFlyer())
    names = pin_names(pm)
    assert names != list(model.joint_names)  # the orders really differ
    pd = pm.createData()
    rng = np.random.default_rng(1)
    qp = pin.randomConfiguration(pm, -np.ones(pm.nq), np.ones(pm.nq))
    vp, ap = rng.normal(size=(2, pm.nv))
    q = dynamics.reorder(model, qp, names, kind="pinocchio_q")
    v, a = (dynamics.reorder(model, x, names, kind="v") for x in (vp, ap))
    tau = dynamics.inverse_dynamics(model, q, v, a)
    tau_pin = pin.rnea(pm, pd, qp, vp, ap)
    np.testing.assert_allclose(dynamics.reorder(model, tau, names, kind="v", inverse=True), tau_pin,
                               rtol=1e-10, atol=1e-9)
    # without the mapping the numbers are silently wrong: the reason this function exists
    assert np.abs(dynamics.inverse_dynamics(model, qp, vp, ap) - tau_pin).max() > 1.0


def test_continuous_joints_map_to_cos_sin_and_back():
    rng = np.random.default_rng(4)
    text = random_urdf(rng, 8, types=("continuous", "revolute", "prismatic"))
    model = dynamics.load_urdf(text)
    pm = pin.buildModelFromXML(text)
    names = pin_names(pm)
    qp = pin.randomConfiguration(pm, -np.ones(pm.nq), np.ones(pm.nq))
    q = dynamics.reorder(model, qp, names, kind="pinocchio_q")
    assert q.shape == (model.nq,) and pm.nq > model.nq
    np.testing.assert_allclose(dynamics.reorder(model, q, names, kind="pinocchio_q", inverse=True), qp, atol=1e-14)
    M = dynamics.mass_matrix(model, q)
    perm = dynamics.reorder(model, np.arange(model.nv, dtype=float), names, kind="v", inverse=True).astype(int)
    Mp = pin.crba(pm, pm.createData(), qp)
    Mp = np.triu(Mp) + np.triu(Mp, 1).T
    np.testing.assert_allclose(M[np.ix_(perm, perm)], Mp, rtol=1e-10, atol=1e-12)


def test_batches_and_a_plain_permutation():
    model = dynamics.load_urdf(random_urdf(np.random.default_rng(2), 5, types=("revolute",)))
    names = list(reversed(model.joint_names))
    X = np.arange(2.0 * model.nq).reshape(2, model.nq)
    Y = dynamics.reorder(model, X, names, kind="q")
    np.testing.assert_array_equal(Y, X[:, ::-1])
    np.testing.assert_array_equal(dynamics.reorder(model, Y, names, kind="q", inverse=True), X)


def test_joint_slices_by_name():
    model = dynamics.load_urdf(erd("talos_data/robots/talos_reduced.urdf"), floating_base=True, strict_inertia=False)
    assert model.q_slice("root_joint") == slice(0, 7) and model.v_slice("root_joint") == slice(0, 6)
    i = model.joint_index("arm_left_4_joint")
    assert model.q_slice("arm_left_4_joint") == slice(model.q_index[i], model.q_index[i] + 1)


@pytest.mark.parametrize("names, message", [
    (["root_joint", "leg_left_1_jiont"], "closest: ['leg_left_1_joint'"),
    (["root_joint"], "missing"),
])
def test_bad_names_say_what_is_wrong(names, message):
    model = dynamics.load_urdf(erd("talos_data/robots/talos_reduced.urdf"), floating_base=True, strict_inertia=False)
    with pytest.raises(dynamics.InputError, match=message.replace("[", r"\[")):
        dynamics.reorder(model, np.zeros(7), names)
    with pytest.raises(dynamics.InputError, match="closest"):
        model.joint_index("arm_left_4_jont")
