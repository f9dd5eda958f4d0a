"""Derivatives of constrained forward dynamics (a and lambda along q, v, tau).

* Every output against central finite differences on the manifold (q moved by dynamics.integrate along each
  tangent coordinate, step 1e-7): the lectures' four-bar closed by its 5-row hinge (rows redundant: the loop is
  planar) and by a 3-row point closure, the hinge-closed four-bar on a floating base (redundant rows whose
  dependency turns with q), a random floating tree with a point, a weld, a hinge and a coupling (on
  and off the constraint manifold, with and without Baumgarte's terms), Panda's fingers coupled by their mimic
  and the Stewart platform's six ball joints.
* Point (CONTACT_3D) and weld (CONTACT_6D) contacts with the world against Pinocchio's
  computeConstraintDynamicsDerivatives in LOCAL_WORLD_ALIGNED (our lambda's frame and sign) on random trees
  (fixed and floating base).  For loops between two moving bodies Pinocchio's analytical derivatives disagree
  with finite differences of its own constraintDynamics (measured with 4.1: relative errors of 0.9 to 4 in the q
  blocks, v and tau blocks right), so the Stewart platform's six ball joints are compared with the latter.
* A batch equals single calls bit for bit; bad input raises InputError naming the argument.
"""

import os

import numpy as np
import pinocchio as pin
import pytest

import dynamics
from robots import OUR_ROBOTS, erd, random_state, random_urdf
from test_constraints_identities import random_loops
from test_constraints_pinocchio import closure
from test_pinocchio import PinMap

H = 1e-7  # along q
#: along v and tau: a and lambda are quadratic in v and linear in tau, so central differences are exact there up
#: to round-off, which a larger step keeps ~100 times below the 1e-6 bound (at 1e-7 it reaches 1e-6 where
#: lambda is large, on the random floating tree with a duplicated closure)
H_VT = 1e-5
FD_TOL = 1e-6
PIN_TOL = 1e-9
PIN3 = int(pin.__version__.split(".")[0]) >= 3
NAMES = ("da_dq", "da_dv", "da_dtau", "dlam_dq", "dlam_dv", "dlam_dtau")


def rel(x, ref):
    return np.abs(np.asarray(x) - ref).max() / max(np.abs(ref).max(), 1e-300)


def finite_differences(model, q, v, tau, baumgarte=None):
    """The six blocks by central differences, q moved along the tangent (dynamics.integrate)."""
    nv = model.nv

    def f(q, v, tau):
        return np.concatenate(dynamics.constrained_forward_dynamics(model, q, v, tau, baumgarte=baumgarte))

    E, F = H * np.eye(nv), H_VT * np.eye(nv)
    cols = [[(f(dynamics.integrate(model, q, e), v, tau) - f(dynamics.integrate(model, q, -e), v, tau)) / (2 * H)
             for e in E],
            [(f(q, v + e, tau) - f(q, v - e, tau)) / (2 * H_VT) for e in F],
            [(f(q, v, tau + e) - f(q, v, tau - e)) / (2 * H_VT) for e in F]]
    D = [np.column_stack(c) for c in cols]
    return [d[:nv] for d in D] + [d[nv:] for d in D]


def check_finite_differences(model, q, v, tau, baumgarte=None):
    ours = dynamics.constrained_forward_dynamics_derivatives(model, q, v, tau, baumgarte=baumgarte)
    errors = {}
    for name, x, ref in zip(NAMES, ours, finite_differences(model, q, v, tau, baumgarte)):
        assert x.shape == ref.shape, name
        errors[name] = rel(x, ref)
    assert max(errors.values()) < FD_TOL, errors
    return errors


# -- finite differences ------------------------------------------------------------------------------------------

FOUR_BAR = os.path.join(OUR_ROBOTS, "four_bar.urdf")


def four_bar(kind):
    if kind == "hinge":
        return dynamics.load_urdf(FOUR_BAR)
    import re
    text = re.sub(r"<loop .*?</loop>", "", open(FOUR_BAR).read(), flags=re.S)
    return dynamics.with_constraints(dynamics.load_urdf(text),
                                     [dynamics.PointConstraint("link2", "link3", (0.35, 0, 0), (0.3, 0, 0))])


@pytest.mark.parametrize("baumgarte", [None, (5.0, 7.0)], ids=["plain", "baumgarte"])
@pytest.mark.parametrize("kind", ["hinge", "point"])
def test_four_bar_against_finite_differences(kind, baumgarte):
    model = four_bar(kind)
    assert [type(c) for c in model.constraints] == [{"hinge": dynamics.RevoluteConstraint,
                                                      "point": dynamics.PointConstraint}[kind]]
    assert model.info["constraints"]["rank"] == 2  # the hinge's 5 rows and the point's 3: planar, redundant
    rng = np.random.default_rng(1)
    for _ in range(2):
        q = dynamics.assemble(model, np.array([rng.uniform(-np.pi, np.pi), 0.5, 1.5]), fixed=["theta1"])
        v = dynamics.project_velocity(model, q, rng.normal(size=3) * 3)
        check_finite_differences(model, q, v, rng.normal(size=3), baumgarte)


def test_redundant_rows_that_turn_with_the_floating_base():
    """The four-bar's hinge on a floating base: 5 rows of rank 2 whose dependent combinations (the loop plane's
    normal) turn with the base, so the minimum-norm lambda's derivative has its null-space term."""
    model = dynamics.load_urdf(FOUR_BAR, floating_base=True)
    assert model.info["constraints"]["rank"] == 2
    rng = np.random.default_rng(2)
    guess = model.neutral()
    guess[:3], guess[3:7], guess[7:] = rng.normal(size=3), [0.3, -0.5, 0.1, 0.8], [0.3, 0.5, 1.5]
    guess[3:7] /= np.linalg.norm(guess[3:7])
    q = dynamics.assemble(model, guess, fixed=["root_joint"])
    v = dynamics.project_velocity(model, q, rng.normal(size=model.nv))
    errors = check_finite_differences(model, q, v, rng.normal(size=model.nv), (2.0, 3.0))
    assert errors["dlam_dq"] < FD_TOL


@pytest.mark.parametrize("seed", range(2))
def test_point_weld_hinge_and_coupling_on_a_floating_tree(seed):
    """A random floating tree with all four kinds; on the manifold, then off it (q moved, v not projected),
    where the weld's and the hinge's Baumgarte terms need the exact derivative of phi (not Phi_q)."""
    model, q, rng = random_loops(seed)
    assert model.joint_types[0] == "floating"
    v, tau = rng.normal(size=model.nv), rng.normal(size=model.nv)
    check_finite_differences(model, q, v, tau)
    check_finite_differences(model, q, v, tau, (4.0, 6.0))
    off = dynamics.integrate(model, q, 0.05 * rng.normal(size=model.nv))
    assert np.abs(dynamics.constraint_residual(model, off)).max() > 1e-3
    check_finite_differences(model, off, v, tau, (4.0, 6.0))


def test_panda_fingers_coupled_by_their_mimic():
    panda = dynamics.load_urdf(erd("panda_description/urdf/panda.urdf"))
    assert [type(c) for c in panda.constraints] == [dynamics.JointCoupling]
    rng = np.random.default_rng(3)
    q = panda.neutral() + rng.uniform(-0.3, 0.3, panda.nq)
    q[-1] = q[-2] = 0.02
    v = dynamics.project_velocity(panda, q, rng.normal(size=panda.nv))
    check_finite_differences(panda, q, v, rng.normal(size=panda.nv), (3.0, 4.0))


STEWART = os.path.join(OUR_ROBOTS, "stewart_platform.urdf")


@pytest.fixture(scope="module")
def stewart():
    from test_constraints_stewart import closed_state
    model = dynamics.load_urdf(STEWART)
    rng = np.random.default_rng(5)
    q, v = closed_state(model, rng)
    return model, q, v, rng.normal(size=model.nv)


def test_stewart_platform_against_finite_differences(stewart):
    model, q, v, tau = stewart
    check_finite_differences(model, q, v, tau, (2.0, 3.0))


# -- Pinocchio ---------------------------------------------------------------------------------------------------

def pinocchio_derivatives(pm, mp, rcms, q, v, tau):
    """Pinocchio's six blocks in our coordinate order."""
    cm, cd = pin.StdVec_RigidConstraintModel(), pin.StdVec_RigidConstraintData()
    for c in rcms:
        cm.append(c)
        cd.append(c.createData())
    pd = pm.createData()
    pin.initConstraintDynamics(pm, pd, cm, cd)
    prox = pin.ProximalSettings(1e-14, 0.0, 1)
    pin.constraintDynamics(pm, pd, mp.q(q), mp.v(v), mp.v(tau), cm, cd, prox)
    pin.computeConstraintDynamicsDerivatives(pm, pd, cm, cd, prox)
    p = mp.v_perm
    blocks = [pd.ddq_dq, pd.ddq_dv, pd.ddq_dtau, pd.dlambda_dq, pd.dlambda_dv, pd.dlambda_dtau]
    return [np.array(b)[np.ix_(p, p)] for b in blocks[:3]] + [np.array(b)[:, p] for b in blocks[3:]]


def check_pinocchio(model, pm, rcms, q, v, tau):
    mp = PinMap(model, pm)
    ours = dynamics.constrained_forward_dynamics_derivatives(model, q, v, tau)
    errors = {name: rel(x, ref) for name, x, ref in zip(NAMES, ours, pinocchio_derivatives(pm, mp, rcms, q, v, tau))}
    assert max(errors.values()) < PIN_TOL, errors
    return errors


needs_pin3 = pytest.mark.skipif(not PIN3, reason="computeConstraintDynamicsDerivatives with "
                                                  "RigidConstraintModel needs Pinocchio 3")


@needs_pin3
@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("kind", ["point", "weld"])
def test_world_contacts_match_pinocchio(seed, kind):
    """A link held at a point or welded to the world (the root link: l0, or at seed 2 the link "world" above a
    floating joint)."""
    rng = np.random.default_rng(300 + seed)
    n = 10 if kind == "point" else 16
    text = random_urdf(rng, n_links=n, types=("revolute", "continuous", "prismatic"), branching=0.3,
                       floating_joint=seed == 2)
    tree = dynamics.load_urdf(text)
    pm = pin.buildModelFromXML(text)
    q, _, _ = random_state(tree, rng)
    for k in rng.permutation(np.arange(1, n)):  # a link with enough joints below the world for independent rows
        con, rcm = closure(tree, pm, kind, f"l{k}", "world" if seed == 2 else "l0", q, rng)
        if np.linalg.matrix_rank(dynamics.constraint_jacobian(dynamics.with_constraints(tree, [con], at=q), q)) \
                == con.rows:
            break
    else:
        pytest.fail("no link with independent rows")
    assert rcm.joint2_id == 0
    model = dynamics.with_constraints(tree, [con], at=q)
    _, v, tau = random_state(model, rng)
    check_pinocchio(model, pm, [rcm], q, dynamics.project_velocity(model, q, v), tau)


def test_stewart_platform_against_pinocchios_dynamics(stewart):
    """The six ball joints close loops between two moving bodies, where Pinocchio's analytical derivatives
    (4.1) disagree with finite differences of its own constraintDynamics (by 100 %): we compare with the
    latter instead (its q moved by pin.integrate)."""
    model, q, v, tau = stewart
    pm = pin.buildModelFromUrdf(STEWART)
    mp = PinMap(model, pm)
    cm, cd = pin.StdVec_RigidConstraintModel(), pin.StdVec_RigidConstraintData()
    for con in model.constraints:
        fa, fb = pm.frames[pm.getFrameId(con.frame_a)], pm.frames[pm.getFrameId(con.frame_b)]
        rcm = pin.RigidConstraintModel(pin.ContactType.CONTACT_3D, pm,
                                       fa.parentJoint, fa.placement * pin.SE3(np.eye(3), np.array(con.point_a)),
                                       fb.parentJoint, fb.placement * pin.SE3(np.eye(3), np.array(con.point_b)),
                                       pin.LOCAL_WORLD_ALIGNED)
        cm.append(rcm)
        cd.append(rcm.createData())
    pd = pm.createData()
    pin.initConstraintDynamics(pm, pd, cm, cd)
    prox = pin.ProximalSettings(1e-14, 0.0, 1)
    qp, vp, tp = mp.q(q), mp.v(v), mp.v(tau)

    def f(qp, vp, tp):
        a = pin.constraintDynamics(pm, pd, qp, vp, tp, cm, cd, prox)
        return np.r_[mp.v_back(a), pd.lambda_c]

    E, F = H * np.eye(pm.nv), H_VT * np.eye(pm.nv)
    D = [np.column_stack([(f(pin.integrate(pm, qp, e), vp, tp) - f(pin.integrate(pm, qp, -e), vp, tp)) / (2 * H)
                          for e in E]),
         np.column_stack([(f(qp, vp + e, tp) - f(qp, vp - e, tp)) / (2 * H_VT) for e in F]),
         np.column_stack([(f(qp, vp, tp + e) - f(qp, vp, tp - e)) / (2 * H_VT) for e in F])]
    D = [d[:, mp.v_perm] for d in D]  # Pinocchio's columns in our order
    ours = dynamics.constrained_forward_dynamics_derivatives(model, q, v, tau)
    nv = model.nv
    for name, x, ref in zip(NAMES, ours, [d[:nv] for d in D] + [d[nv:] for d in D]):
        assert rel(x, ref) < FD_TOL, name


# -- batch and bad input -----------------------------------------------------------------------------------------

def test_batch_equals_single_calls_bit_for_bit():
    model, q, rng = random_loops(0)
    B = 5
    Q = np.array([dynamics.integrate(model, q, 0.01 * rng.normal(size=model.nv)) for _ in range(B)])
    V, T = rng.normal(size=(B, model.nv)), rng.normal(size=(B, model.nv))
    batch = dynamics.constrained_forward_dynamics_derivatives(model, Q, V, T, baumgarte=(1.0, 2.0))
    m = dynamics.constraint_residual(model, q).shape[0]
    assert [x.shape for x in batch] == [(B, model.nv, model.nv)] * 3 + [(B, m, model.nv)] * 3
    for b in range(B):
        one = dynamics.constrained_forward_dynamics_derivatives(model, Q[b], V[b], T[b], baumgarte=(1.0, 2.0))
        for x, y in zip(batch, one):
            assert np.array_equal(x[b], y)
    # one v and tau shared by the batch
    shared = dynamics.constrained_forward_dynamics_derivatives(model, Q, V[0], T[0])
    assert np.array_equal(shared[3][2], dynamics.constrained_forward_dynamics_derivatives(model, Q[2], V[0], T[0])[3])


def test_bad_input_names_the_argument():
    model = four_bar("point")
    q, v, tau = model.neutral(), np.zeros(3), np.zeros(3)
    f = dynamics.constrained_forward_dynamics_derivatives
    with pytest.raises(dynamics.InputError, match="no constraints"):
        f(dynamics.load_urdf(os.path.join(OUR_ROBOTS, "planar_3r.urdf")), q, v, tau)
    with pytest.raises(dynamics.InputError, match="^q"):
        f(model, np.zeros(4), v, tau)
    with pytest.raises(dynamics.InputError, match="^v"):
        f(model, q, np.zeros(2), tau)
    with pytest.raises(dynamics.InputError, match="^tau"):
        f(model, q, v, np.zeros((2, 4)))
    with pytest.raises(dynamics.InputError, match="^tau"):
        f(model, q, v, [0.0, np.nan, 0.0])
    with pytest.raises(dynamics.InputError, match="baumgarte"):
        f(model, q, v, tau, baumgarte=(1.0, -2.0))
