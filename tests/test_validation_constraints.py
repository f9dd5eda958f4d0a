"""Constraints that can never hold are refused, redundant ones warned about, and a simulation that starts off
the constraint manifold (or drifts far from it) says so (issue 25, item 6).

The robot: a planar 3R arm in the world x-y plane, links 1 m (joint origins at x = 0, 1, 2 m), every joint
about z with limits [-3, 3] rad; so link 3's point (0.5, 0, 0) is at x = 2.5 m at q = 0.
"""

import re
import warnings

import numpy as np
import pytest

import dynamics
from dynamics import InputError, JointCoupling, PointConstraint, URDFError, WeldConstraint


def arm(extra="", mimic=""):
    s = '<robot name="arm"><link name="base"/>'
    prev = "base"
    for i in (1, 2, 3):
        s += (f'<link name="l{i}"><inertial><mass value="1"/><origin xyz="0.5 0 0"/>'
              f'<inertia ixx="0.01" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial></link>'
              f'<joint name="j{i}" type="revolute"><parent link="{prev}"/><child link="l{i}"/>'
              f'<origin xyz="{0 if i == 1 else 1} 0 0"/><axis xyz="0 0 1"/>'
              f'<limit lower="-3" upper="3" effort="10" velocity="10"/>{mimic if i == 2 else ""}</joint>')
        prev = f"l{i}"
    return s + extra + "</robot>"


def loop(kind, a, b, xyz_a="0 0 0", xyz_b="0 0 0", name="rod"):
    return (f'<loop name="{name}" type="{kind}"><link_a name="{a}" xyz="{xyz_a}"/><link_b name="{b}" '
            f'xyz="{xyz_b}"/></loop>')


# -- couplings ------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("attr", ["multiplier", "offset"])
def test_a_coupling_beyond_what_float64_carries_is_refused(attr):
    """multiplier or offset 1e308: q = [0, 1e308, 0] 'satisfies' it; refused, naming the bound."""
    with pytest.raises(InputError, match=rf"JointCoupling {attr}: \|{attr}\| = 1e\+308 exceeds 1e\+04"):
        JointCoupling("j2", "j1", **{attr: 1e308})
    with pytest.raises(URDFError, match=rf"joint 'j2': <mimic>: JointCoupling {attr}: .*1e\+308 exceeds 1e\+04"):
        dynamics.load_urdf(arm(mimic=f'<mimic joint="j1" {attr}="1e308"/>'))
    # a gear ratio of 100 and an offset of a few radians are ordinary
    c = JointCoupling("j2", "j1", multiplier=-100.0, offset=3.0)
    assert (c.multiplier, c.offset) == (-100.0, 3.0)


def test_a_mimic_cycle_is_refused():
    model = dynamics.load_urdf(arm())
    with pytest.raises(InputError, match=r"the couplings form a cycle: j1 follows j2 follows j1"):
        dynamics.with_constraints(model, [JointCoupling("j1", "j2"), JointCoupling("j2", "j1")])
    with pytest.raises(InputError, match=r"cycle: j1 follows j3 follows j2 follows j1"):
        dynamics.with_constraints(model, [JointCoupling("j1", "j3"), JointCoupling("j3", "j2"),
                                          JointCoupling("j2", "j1")])
    # a chain of couplings (j3 follows j2 follows j1) is fine
    ok = dynamics.with_constraints(model, [JointCoupling("j3", "j2"), JointCoupling("j2", "j1")])
    assert ok.info["constraints"]["rank"] == 2


# -- loops ------------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("kind", ["weld", "point"])
def test_a_loop_of_a_link_to_itself_is_refused(kind):
    with pytest.raises(URDFError, match=rf"{kind.title()}Constraint 'rod': both anchors are fixed to body 'l2'"):
        dynamics.load_urdf(arm(loop(kind, "l2", "l2", xyz_b="1 0 0")))
    model = dynamics.load_urdf(arm())
    with pytest.raises(InputError, match=r"both anchors are fixed to body 'l3'"):
        dynamics.with_constraints(model, WeldConstraint("l3", "l3"))


def test_a_loop_anchored_out_of_reach_is_refused():
    """Link 3's anchor 100 m out, the base's at the origin: the anchors' distance is at least 100 - 2 = 98 m
    (the chain between them: 100 m, then 1, 1 and 0 m between joint origins), so they never meet."""
    with pytest.raises(URDFError, match=r"PointConstraint 'rod': cannot close in any configuration: the segment "
                                        r"of 100 m from the anchor on 'l3' to joint 'j3' is longer than the 2 m of the "
                                        r"rest of the chain between the anchors, so they stay at least 98 m apart"):
        dynamics.load_urdf(arm(loop("point", "l3", "base", xyz_a="100 0 0")))
    # the same loop within reach closes: (0, 2.4) m is 2.4 <= 2.5 m from the base
    model = dynamics.load_urdf(arm(loop("point", "l3", "base", xyz_a="0.5 0 0", xyz_b="0 2.4 0")))
    assert model.info["constraints"]["closed_near_assembly"] and not model.warnings


def test_a_loop_that_does_not_close_near_assembly_warns():
    """Within reach by the lengths (2.4 <= 2.5 m) but out of the arm's plane: it cannot close; a warning, with
    the residual left: the nearest the tip comes to (0, 0, 2.4) is the origin, 2.4 m away."""
    with pytest.warns(UserWarning, match=r"do not close near the assembly configuration: max \|phi\| = 2\.4 "):
        model = dynamics.load_urdf(arm(loop("point", "l3", "base", xyz_a="0.5 0 0", xyz_b="0 0 2.4")))
    assert model.info["constraints"]["closed_near_assembly"] is False
    assert any("do not close near the assembly configuration" in w for w in model.warnings)


def test_identical_loops_warn_about_redundant_rows():
    """50 copies of one point loop: 150 rows of rank 2 (planar); the 49 copies add nothing."""
    rods = "".join(loop("point", "l3", "base", "0.5 0 0", "0 2.4 0", name=f"rod{k}") for k in range(50))
    with pytest.warns(UserWarning, match=r"49 constraints add no independent rows to those before them: "
                                         r"'rod1', 'rod2', .*; the multipliers are then not unique"):
        model = dynamics.load_urdf(arm(rods))
    assert model.info["constraints"]["rows"] == 150 and model.info["constraints"]["rank"] == 2
    assert sum("add no independent rows" in w for w in model.warnings) == 1
    with warnings.catch_warnings():  # one loop: its rank-2 rows in a plane are no redundancy
        warnings.simplefilter("error")
        one = dynamics.load_urdf(arm(loop("point", "l3", "base", "0.5 0 0", "0 2.4 0")))
    assert not one.warnings


def test_a_weld_placement_must_be_homogeneous():
    T = np.eye(4)
    T[3] = 5.0
    with pytest.raises(InputError, match=re.escape("WeldConstraint placement: the bottom row is [5, 5, 5, 5]; "
                                                   "expected [0, 0, 0, 1]")):
        WeldConstraint("l1", "l3", T)


# -- simulate from off the manifold ----------------------------------------------------------------------------

def test_simulate_from_off_the_manifold_warns_with_the_residual():
    """The tip held at (0, 2.4); starting at q0 = (0.3, 0, 0) the tip is at 2.5 (cos 0.3, sin 0.3), so
    phi = (2.5 cos 0.3, 2.5 sin 0.3 - 2.4, 0) and max |phi| = 2.5 cos 0.3 = 2.388 m.  The report says so (the
    report's warnings reach Python's warnings where the report is emitted, issue 25 item 10)."""
    model = dynamics.with_constraints(dynamics.load_urdf(arm()), PointConstraint("l3", "base", (0.5, 0, 0),
                                                                                 (0, 2.4, 0)))
    q0 = np.array([0.3, 0.0, 0.0])
    tr = dynamics.simulate(model, q0, np.zeros(3), 0.05)
    off = 2.5 * np.cos(0.3)
    assert any(f"q0: off the constraints: max |phi(q0)| = {off:.4g} > 1e-06 (at PointConstraint 0 ('l3', "
               f"'base'))" in w for w in tr.report["warnings"]), tr.report["warnings"]
    # from an assembled start there is nothing to say
    q1 = dynamics.assemble(model, np.array([1.4, 0.3, 0.3]), fixed=["j1"])
    tr = dynamics.simulate(model, q1, np.zeros(3), 0.05)
    assert not [w for w in tr.report["warnings"] if "phi" in w or "constraint" in w], tr.report["warnings"]


def test_a_simulation_that_drifts_far_warns():
    """No Baumgarte, a loose tolerance, 2 s of spinning (no gravity in the arm's plane; a push along the
    mechanism's one free motion): the loop opens by more than 1e-6 m; the report says so rather than a silent
    status "ok"."""
    model = dynamics.with_constraints(dynamics.load_urdf(arm()), PointConstraint("l3", "base", (0.5, 0, 0),
                                                                                 (0, 2.4, 0)))
    q0 = dynamics.assemble(model, np.array([1.4, 0.3, 0.3]), fixed=["j1"])
    v0 = dynamics.project_velocity(model, q0, np.array([5.0, 0, 0]))
    tr = dynamics.simulate(model, q0, v0, 2.0, rtol=1e-3, atol=1e-3, baumgarte=(0, 0),
                           error_estimate="none")
    phi = np.abs(dynamics.constraint_residual(model, tr.q)).max()  # recomputed at the samples
    drift = tr.report["constraint_drift"]["position"]
    assert phi <= drift * (1 + 1e-9) and drift > 1e-6
    assert any(re.search(r"constraint_drift: the constraints opened by up to .* > 1e-06", w)
               for w in tr.report["warnings"])


def test_lock_joints_drops_a_loop_left_on_one_body_when_it_closes():
    """A pin between l2 (1.5, 0, 0) and l3 (0.5, 0, 0), which holds at q3 = 0: locking j3 at 0 leaves both ends
    on one body, closed (dropped: it constrains nothing); at 0.5 rad they are 0.5 (cos 0.5 - 1, sin 0.5) apart,
    max 0.5 sin 0.5 = 0.2397 m (refused)."""
    model = dynamics.with_constraints(dynamics.load_urdf(arm()), PointConstraint("l2", "l3", (1.5, 0, 0),
                                                                                 (0.5, 0, 0), name="pin"))
    locked = dynamics.lock_joints(model, {"j3": 0.0})
    assert locked.constraints == () and locked.nv == 2
    with pytest.raises(InputError, match=rf"both ends of loop 'pin' on one rigid body {0.5 * np.sin(0.5):.3g} apart"):
        dynamics.lock_joints(model, {"j3": 0.5})


def test_simulate_from_off_a_coupling_warns():
    """j2 = 2 j1 + 0.1 started at q = (0.3, 0, 0): phi = 0 - 2 * 0.3 - 0.1 = -0.7."""
    model = dynamics.with_constraints(dynamics.load_urdf(arm()), JointCoupling("j2", "j1", 2.0, 0.1, name="gear"))
    tr = dynamics.simulate(model, np.array([0.3, 0.0, 0.0]), np.zeros(3), 0.05)
    assert any("max |phi(q0)| = 0.7 > 1e-06 (at JointCoupling 'gear')" in w for w in tr.report["warnings"])


def test_a_coupling_outside_the_limits_warns():
    """j2 = j1 + 10 spans [7, 13] over j1's [-3, 3], outside j2's [-3, 3]: legal (the limits are soft) but it
    holds nowhere the URDF lets the joints go."""
    with pytest.warns(UserWarning, match=r"JointCoupling 0 \('j2', 'j1'\): j2 = 1 j1 \+ 10 spans \[7, 13\] over "
                                         r"j1's limits \[-3, 3\], outside j2's \[-3, 3\]"):
        model = dynamics.load_urdf(arm(mimic='<mimic joint="j1" offset="10"/>'))
    assert any("holds nowhere within the limits" in w for w in model.warnings)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        dynamics.load_urdf(arm(mimic='<mimic joint="j1" multiplier="-1" offset="0.5"/>'))
