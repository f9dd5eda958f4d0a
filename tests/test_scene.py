"""Leaving out what a scene does not need: locked joints, pruned links, skipped terms."""

import numpy as np
import pinocchio as pin
import pytest

import dynamics
from dynamics import _core
from dynamics.rnea import skipped_terms
from robots import erd, random_state, random_urdf
from test_pinocchio import PinMap, compare

LOCK_CASES = [
    ("talos_data/robots/talos_full_v2.urdf", True, ("arm_", "head_", "gripper_")),
    ("talos_data/robots/talos_reduced.urdf", True, ("arm_right", "torso_")),
    ("panda_description/urdf/panda.urdf", False, ("panda_finger", "panda_joint7")),
    ("ur_description/urdf/ur5_robot.urdf", False, ("wrist_",)),
    ("solo_description/robots/solo12.urdf", True, ("FL_", "HR_")),
    ("anymal_b_simple_description/robots/anymal.urdf", True, ("LF_",)),
]


@pytest.mark.parametrize("rel, floating, prefixes", LOCK_CASES, ids=[c[0].split("/")[-1] for c in LOCK_CASES])
def test_locked_model_matches_pinocchio_reduced_model(rel, floating, prefixes):
    path = erd(rel)
    # the open tree, as Pinocchio builds it (mimic=False): locking a mimic joint apart from its leader is then
    # allowed (with couplings, lock_joints refuses inconsistent values: tests/test_constraints_identities.py)
    model = dynamics.load_urdf(path, floating_base=floating, strict_inertia=False, mimic="independent")
    pm = pin.buildModelFromUrdf(path, pin.JointModelFreeFlyer()) if floating else pin.buildModelFromUrdf(path)
    rng = np.random.default_rng(1)
    q, _, _ = random_state(model, rng)
    lock = [n for n in model.joint_names if n.startswith(prefixes)]
    assert lock
    reduced = dynamics.lock_joints(model, {n: q[model.q_index[model.joint_index(n)]] for n in lock})
    assert reduced.nv == model.nv - len(lock)
    assert set(reduced.summary()["locked_joints"]) == set(lock)
    pr = pin.buildReducedModel(pm, [pm.getJointId(n) for n in lock], PinMap(model, pm).q(q))
    compare(reduced, pr, rng, n_states=2)


@pytest.mark.parametrize("seed", range(6))
def test_locked_random_trees_match_pinocchio(seed):
    rng = np.random.default_rng(200 + seed)
    text = random_urdf(rng, n_links=10)
    model = dynamics.load_urdf(text)
    pm = pin.buildModelFromXML(text)
    q, _, _ = random_state(model, rng)
    lock = list(rng.choice(model.joint_names, size=3, replace=False))
    reduced = dynamics.lock_joints(model, {n: q[model.q_index[model.joint_index(n)]] for n in lock})
    pr = pin.buildReducedModel(pm, [pm.getJointId(n) for n in lock], PinMap(model, pm).q(q))
    compare(reduced, pr, rng)


def test_locked_model_equals_full_model_with_those_joints_held():
    """Locking at q_l is the full model with q_l held there: the reduced M is the sub-matrix of the full M,
    and the torques of the free joints agree when the locked joints do not accelerate."""
    model = dynamics.load_urdf(erd("panda_description/urdf/panda.urdf"))
    rng = np.random.default_rng(3)
    q, v, a = random_state(model, rng)
    lock = {"panda_joint2": q[1], "panda_joint5": q[4]}
    keep = [k for k in range(model.nv) if k not in (1, 4)]
    reduced = dynamics.lock_joints(model, lock)
    v[[1, 4]] = a[[1, 4]] = 0
    np.testing.assert_allclose(dynamics.mass_matrix(reduced, q[keep]), dynamics.mass_matrix(model, q)[np.ix_(keep, keep)],
                               atol=1e-12)
    np.testing.assert_allclose(dynamics.inverse_dynamics(reduced, q[keep], v[keep], a[keep]),
                               dynamics.inverse_dynamics(model, q, v, a)[keep], atol=1e-10)


def test_lock_joints_rejects_bad_requests():
    model = dynamics.load_urdf(erd("panda_description/urdf/panda.urdf"))
    with pytest.raises(dynamics.InputError, match="no movable joint named 'elbow'"):
        dynamics.lock_joints(model, {"elbow": 0.0})
    with pytest.raises(dynamics.InputError, match="panda_joint1"):
        dynamics.lock_joints(model, {"panda_joint1": [0.0, 1.0]})
    with pytest.raises(dynamics.InputError, match="panda_joint1"):
        dynamics.lock_joints(model, {"panda_joint1": float("nan")})
    floating = dynamics.load_urdf(erd("panda_description/urdf/panda.urdf"), floating_base=True)
    with pytest.raises(dynamics.InputError, match="quaternion"):
        dynamics.lock_joints(floating, {"root_joint": [0, 0, 0, 0, 0, 0, 0]})


def test_pruned_massless_leaves_change_no_number():
    rng = np.random.default_rng(9)
    text = random_urdf(rng, n_links=8, types=("revolute", "prismatic"))
    extra = "".join(f'<link name="sensor{i}"/><joint name="mount{i}" type="fixed"><parent link="l{i}"/>'
                    f'<child link="sensor{i}"/><origin xyz="0.1 0.2 0.3" rpy="0.1 0.2 0.3"/></joint>' for i in range(8))
    plain = dynamics.load_urdf(text)
    decorated = dynamics.load_urdf(text.replace("</robot>", extra + "</robot>"))
    assert decorated.nbodies == plain.nbodies
    assert sorted(decorated.summary()["links_pruned"]) == sorted(f"sensor{i}" for i in range(8))
    assert set(f"sensor{i}" for i in range(8)) <= set(decorated.frames)  # frames remembered
    q, v, a = random_state(plain, rng)
    for f in (dynamics.inverse_dynamics,):
        np.testing.assert_array_equal(f(plain, q, v, a), f(decorated, q, v, a))
    np.testing.assert_array_equal(dynamics.mass_matrix(plain, q), dynamics.mass_matrix(decorated, q))


def test_skipped_terms_give_the_same_numbers_as_the_full_computation():
    model = dynamics.load_urdf(erd("talos_data/robots/talos_full_v2.urdf"), floating_base=True,
                            mimic="independent")  # the tree kernels against the tree entry points
    rng = np.random.default_rng(4)
    Q, V, A = (np.array(x) for x in zip(*(random_state(model, rng) for _ in range(200))))
    Z = np.zeros_like(V)
    g = np.array(model.gravity)
    F = np.zeros((1, 0, 6))
    full = np.empty_like(V)

    def rnea(V, A):  # the core's RNEA with every term (with_v, with_a), on one thread
        _core.rnea_batch(model.core, Q, V, A, F, g, True, True, full, 1, np.inf)

    # zero velocity and acceleration: gravity torques vs the full RNEA on explicit zeros
    rnea(Z, Z)
    # gravity torques take the subtree-weight shortcut: same numbers up to round-off
    np.testing.assert_allclose(dynamics.gravity_torques(model, Q), full, rtol=0, atol=1e-12 * np.abs(full).max())
    rnea(V, Z)
    np.testing.assert_array_equal(dynamics.bias_forces(model, Q, V), full)
    rnea(Z, A)
    np.testing.assert_array_equal(dynamics.inverse_dynamics(model, Q, Z, A), full)
    _core.aba_batch(model.core, Q, Z, A, F, g, True, full, 1, np.inf)
    np.testing.assert_array_equal(dynamics.forward_dynamics(model, Q, Z, A), full)
    assert skipped_terms(v=Z, a=A) == ["velocity products"]
    assert skipped_terms(v=V, a=None, gravity=[0, 0, 0]) == ["joint accelerations", "gravity"]
