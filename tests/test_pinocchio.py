"""Every algorithm against Pinocchio (the reference), on all example-robot-data URDFs and random trees.

Joint order differs (ours: depth first in document order), so coordinates are mapped by joint name, and a
continuous joint's single angle maps to Pinocchio's (cos, sin) pair.  Tolerance: relative error 1e-10.
"""

import numpy as np
import pinocchio as pin
import pytest

import dynamics
from dynamics.joints import kind_of
from robots import ALL_TYPES, erd, erd_urdfs, random_state, random_urdf

RTOL = 1e-10


class PinMap:
    """Map our q, v to Pinocchio's for the same URDF."""

    def __init__(self, model, pm):
        self.model, self.pm = model, pm
        self.q_parts, self.v_perm = [], np.empty(model.nv, dtype=int)
        for i, name in enumerate(model.joint_names):
            jid = pm.getJointId(name)
            assert jid < pm.njoints, f"Pinocchio has no joint {name}"
            j = pm.joints[jid]
            k, n = model.q_index[i], model.nv_joint[i]
            self.q_parts.append((model.joint_types[i], k, j.idx_q, j.nq))
            self.v_perm[model.v_index[i]:model.v_index[i] + n] = np.arange(j.idx_v, j.idx_v + j.nv)
            self.body_joint = None
        assert pm.nv == model.nv

    def q(self, q):
        """Pinocchio's q: the same coordinates (a quaternion, a planar joint's (cos, sin) normalised: Pinocchio
        takes them as given), a continuous joint's angle as (cos, sin)."""
        out = pin.neutral(self.pm)
        for jtype, k, kp, nqp in self.q_parts:
            kind = kind_of(jtype)
            if nqp == 2 and kind.nq == 1:
                out[kp:kp + 2] = np.cos(q[k]), np.sin(q[k])
                continue
            x = np.array(q[k:k + kind.nq], float)
            if kind.unit:
                o, n = kind.unit
                x[o:o + n] /= np.linalg.norm(x[o:o + n])
            out[kp:kp + kind.nq] = x
        return out

    def v(self, v):
        out = np.zeros(self.pm.nv)
        out[self.v_perm] = v
        return out

    def v_back(self, vp):
        return vp[self.v_perm]

    def M_back(self, Mp):
        Mp = np.triu(Mp) + np.triu(Mp, 1).T
        return Mp[np.ix_(self.v_perm, self.v_perm)]


def pin_model(text, model, floating=False):
    """Pinocchio's model of the URDF ``text`` that ``model`` was loaded from.  Its URDF parser knows no
    spherical joint and puts every planar joint's plane normal to z: the model is read with each spherical
    joint as a continuous one, then rebuilt with JointModelSpherical there and, for a planar joint of axis a,
    Pinocchio's joint frame turned by Ra (z onto a, read from our S; checked to be such a rotation), so that
    its motion Ra Planar_z(q) Ra^T is ours: the joint's placement P becomes P Ra, and what hangs from the
    joint (inertia, child joints, frames) is expressed in the turned frame (Ra^T X)."""
    args = [pin.JointModelFreeFlyer()] if floating else []
    pm = pin.buildModelFromXML(text.replace('type="spherical"', 'type="continuous"'), *args)
    kinds = {name: t for name, t in zip(model.joint_names, model.joint_types)}
    if not any(t in ("spherical", "planar") for t in kinds.values()):
        return pm
    turn = {}  # pinocchio joint id -> SE3(Ra, 0) of a planar joint
    for i, name in enumerate(model.joint_names):
        if kinds[name] == "planar":
            k = model.v_index[i]
            S = model.tree.S
            Ra = np.column_stack([S[k, 3:], S[k + 1, 3:], S[k + 2, :3]])
            assert np.allclose(Ra.T @ Ra, np.eye(3), atol=1e-14) and np.linalg.det(Ra) > 0
            assert np.allclose(Ra[:, 2], model.tree.axis[i], atol=1e-15)
            turn[pm.getJointId(name)] = pin.SE3(Ra, np.zeros(3))
    out = pin.Model()
    out.gravity = pm.gravity
    for j in range(1, pm.njoints):
        name, parent = pm.names[j], pm.parents[j]
        jm = pin.JointModelSpherical() if kinds.get(name) == "spherical" else pm.joints[j]
        P = pm.jointPlacements[j]
        if parent in turn:
            P = turn[parent].actInv(P)
        if j in turn:
            P = P * turn[j]
        out.addJoint(parent, jm, P, name)
    for fr in list(pm.frames)[1:]:
        # Pinocchio 3 names a frame's joint and frame parentJoint and parentFrame; 2.x parent and previousFrame
        joint = fr.parentJoint if hasattr(fr, "parentJoint") else fr.parent
        previous = fr.parentFrame if hasattr(fr, "parentFrame") else fr.previousFrame
        placement = turn[joint].actInv(fr.placement) if joint in turn else fr.placement
        out.addFrame(pin.Frame(fr.name, joint, previous, placement, fr.type), False)
    for j in range(1, pm.njoints):
        out.inertias[j] = turn[j].actInv(pm.inertias[j]) if j in turn else pm.inertias[j]
    PIN_TURNS[id(out)] = (out, turn)
    return out


#: id(Pinocchio model) -> (that model, its turned planar joints {joint id: SE3(Ra, 0)}) (pin_model)
PIN_TURNS = {}


def pin_force(pm, jid, F):
    """Our body wrench F = [force, torque] (body frame) as Pinocchio's Force in joint jid's frame (turned:
    pin_model)."""
    force = pin.Force(F[:3], F[3:])
    model_turn = PIN_TURNS.get(id(pm))
    if model_turn is not None and model_turn[0] is pm and jid in model_turn[1]:
        force = model_turn[1][jid].actInv(force)
    return force


def a_tol(M):
    """1e-10, or what the conditioning of M allows (a relative error of cond(M) eps is unavoidable)."""
    return max(RTOL, 10 * np.linalg.cond(M) * np.finfo(float).eps)


def rel_err(x, ref):
    return np.linalg.norm(np.asarray(x) - ref) / max(np.linalg.norm(ref), 1.0)


def compare(model, pm, rng, n_states=3, with_fext=True):
    pd = pm.createData()
    mp = PinMap(model, pm)
    for _ in range(n_states):
        q, v, a = random_state(model, rng)
        qp, vp, ap = mp.q(q), mp.v(v), mp.v(a)
        tau = dynamics.inverse_dynamics(model, q, v, a)
        assert rel_err(tau, mp.v_back(pin.rnea(pm, pd, qp, vp, ap))) < RTOL
        M = dynamics.mass_matrix(model, q)
        assert rel_err(M, mp.M_back(pin.crba(pm, pd, qp))) < RTOL
        singular = False
        try:
            acc = dynamics.forward_dynamics(model, q, v, tau)
        except dynamics.InputError as e:
            # a joint that moves no mass (e.g. Romeo's thumb): M really is singular, and the error names it
            name = str(e).split("'")[1]
            k = model.v_index[model.joint_index(name)]
            assert "singular" in str(e) and abs(M[k, k]) < 1e-12, str(e)
            singular = True
        if not singular:
            assert rel_err(acc, mp.v_back(pin.aba(pm, pd, qp, vp, mp.v(tau)))) < a_tol(M)
        g = dynamics.gravity_torques(model, q)
        assert rel_err(g, mp.v_back(pin.computeGeneralizedGravity(pm, pd, qp))) < RTOL
        b = dynamics.bias_forces(model, q, v)
        assert rel_err(b, mp.v_back(pin.nonLinearEffects(pm, pd, qp, vp))) < RTOL
        ke = dynamics.kinetic_energy(model, q, v)
        assert abs(ke - pin.computeKineticEnergy(pm, pd, qp, vp)) <= RTOL * max(1.0, abs(ke))
        if with_fext:
            # one random wrench per body, in the body (= joint) frame, Pinocchio's [force, torque] layout
            F = rng.normal(size=(model.nbodies, 6))
            fext = [pin.Force.Zero() for _ in range(pm.njoints)]
            for i, name in enumerate(model.joint_names):
                fext[pm.getJointId(name)] = pin_force(pm, pm.getJointId(name), F[i])
            tau_f = dynamics.inverse_dynamics(model, q, v, a, f_ext=F)
            assert rel_err(tau_f, mp.v_back(pin.rnea(pm, pd, qp, vp, ap, fext))) < RTOL
            if not singular:
                acc_f = dynamics.forward_dynamics(model, q, v, tau_f, f_ext=F)
                assert rel_err(acc_f, a) < a_tol(M)


def _pin_loads(path, floating):
    try:
        if floating:
            return pin.buildModelFromUrdf(path, pin.JointModelFreeFlyer())
        return pin.buildModelFromUrdf(path)
    except Exception:  # Pinocchio refuses it: nothing to compare against
        return None


ERD = erd_urdfs()


@pytest.mark.parametrize("rel", ERD)
@pytest.mark.parametrize("floating", [False, True], ids=["fixed", "floating"])
def test_example_robot_data_matches_pinocchio(rel, floating):
    path = erd(rel)
    pm = _pin_loads(path, floating)
    if pm is None:
        pytest.skip("Pinocchio does not load this URDF")
    # the open tree's dynamics, as Pinocchio's buildModelFromUrdf builds it (mimic=False): mimic joints free
    # (the couplings are tested in tests/test_constraints_pinocchio.py)
    try:
        model = dynamics.load_urdf(path, floating_base=floating, mimic="independent")
    except dynamics.URDFError as e:
        # an inertia no rigid body can have (several published URDFs): the error says so, and a non-physical
        # inertia can still be loaded on request, as Pinocchio does
        assert "inertia" in str(e) and "strict_inertia=False" in str(e), str(e)
        model = dynamics.load_urdf(path, floating_base=floating, strict_inertia=False, mimic="independent")
        assert any("inertia" in w for w in model.warnings)
    if pm.nv != model.nv:  # a massless root with a URDF floating joint etc.: must be explained
        pytest.fail(f"nv differs: ours {model.nv}, Pinocchio {pm.nv}")
    if model.nv == 0:
        return
    compare(model, pm, np.random.default_rng(abs(hash(rel)) % 2**32), n_states=2)


@pytest.mark.parametrize("seed", range(12))
def test_random_trees_match_pinocchio(seed):
    rng = np.random.default_rng(seed)
    text = random_urdf(rng, n_links=int(rng.integers(2, 14)), floating_joint=seed % 3 == 0)
    model = dynamics.load_urdf(text)
    pm = pin.buildModelFromXML(text)
    compare(model, pm, rng)


@pytest.mark.parametrize("seed", range(6))
def test_random_trees_with_every_joint_type_match_pinocchio(seed):
    """Trees mixing revolute, continuous, prismatic, fixed, planar (its axis z or not) and spherical joints,
    with a URDF floating root, the floating_base option, or a fixed base."""
    rng = np.random.default_rng(300 + seed)
    text = random_urdf(rng, n_links=int(rng.integers(5, 12)), types=ALL_TYPES, floating_joint=seed % 3 == 0)
    floating = seed % 3 == 1
    model = dynamics.load_urdf(text, floating_base=floating)
    assert {"planar", "spherical"} & set(model.joint_types)
    compare(model, pin_model(text, model, floating), rng)


@pytest.mark.parametrize("seed", range(4))
def test_random_trees_floating_base_option_matches_pinocchio_freeflyer(seed):
    rng = np.random.default_rng(100 + seed)
    text = random_urdf(rng, n_links=7)
    model = dynamics.load_urdf(text, floating_base=True)
    assert model.joint_names[0] == "root_joint" and model.nq == model.nv + 1
    compare(model, pin.buildModelFromXML(text, pin.JointModelFreeFlyer()), rng)


def test_batch_equals_single_states():
    model = dynamics.load_urdf(erd("talos_data/robots/talos_full_v2.urdf"), floating_base=True,
                               mimic="independent")  # the tree: ABA(RNEA(a)) = a for any a
    rng = np.random.default_rng(7)
    states = [random_state(model, rng) for _ in range(300)]
    Q, V, A = (np.array(x) for x in zip(*states))
    T = dynamics.inverse_dynamics(model, Q, V, A)
    M = dynamics.mass_matrix(model, Q)
    acc = dynamics.forward_dynamics(model, Q, V, T)
    for k in (0, 150, 299):
        np.testing.assert_array_equal(T[k], dynamics.inverse_dynamics(model, Q[k], V[k], A[k]))
        np.testing.assert_array_equal(M[k], dynamics.mass_matrix(model, Q[k]))
    np.testing.assert_allclose(acc, A, atol=1e-8 * np.abs(A).max())


def test_concurrent_calls_from_threads_are_safe_and_identical():
    from concurrent.futures import ThreadPoolExecutor

    model = dynamics.load_urdf(erd("panda_description/urdf/panda.urdf"))
    rng = np.random.default_rng(8)
    Q, V, A = (np.array(x) for x in zip(*(random_state(model, rng) for _ in range(500))))
    ref_tau = dynamics.inverse_dynamics(model, Q, V, A)
    ref_acc = dynamics.forward_dynamics(model, Q, V, ref_tau)
    ref_M = dynamics.mass_matrix(model, Q[:50])

    def work(k):
        if k % 3 == 0:
            return np.array_equal(dynamics.inverse_dynamics(model, Q, V, A), ref_tau)
        if k % 3 == 1:
            return np.array_equal(dynamics.forward_dynamics(model, Q, V, ref_tau), ref_acc)
        return all(np.array_equal(dynamics.mass_matrix(model, Q[j]), ref_M[j]) for j in range(50))

    with ThreadPoolExecutor(8) as pool:
        assert all(pool.map(work, range(48)))
