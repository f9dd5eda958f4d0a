"""URDF loading: what is honoured, what is merged, and every refusal names its culprit."""

import os
import time

import numpy as np
import pytest

import dynamics
from dynamics import URDFError
from robots import erd

INERTIA = '<inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/>'


def link(name, mass=1.0, inertia=INERTIA, origin=""):
    return f'<link name="{name}"><inertial>{origin}<mass value="{mass}"/>{inertia}</inertial></link>'


def joint(name, parent, child, jtype="revolute", extra=""):
    return (f'<joint name="{name}" type="{jtype}"><parent link="{parent}"/><child link="{child}"/>'
            f'<axis xyz="0 0 1"/>{extra}</joint>')


def robot(*parts, name="r"):
    return f'<robot name="{name}">' + "".join(parts) + "</robot>"


# -- refusals name the culprit -------------------------------------------------------------------------

@pytest.mark.parametrize("text, culprit", [
    ('<notrobot name="x"/>', "<notrobot>"),
    (robot(), "no <link>"),
    (robot(link("a"), joint("j", "a", "ghost")), "ghost"),
    (robot(link("a"), joint("j", "nobody", "a")), "nobody"),
    (robot(link("a"), link("b"), link("c"), joint("j1", "a", "c"), joint("j2", "b", "c")), "'c' has two parents"),
    (robot(link("a"), link("b"), joint("j1", "a", "b"), joint("j2", "b", "a")), "cycle"),
    (robot(link("a"), link("b"), link("c"), link("d"), joint("j1", "a", "b"), joint("j2", "c", "d")),
     "more than one root"),
    (robot(link("a"), link("b"), link("c"), joint("j0", "a", "b"), joint("j1", "b", "c"), joint("j2", "c", "b")),
     "two parents"),
    (robot(link("a"), link("b", mass=-1), joint("j", "a", "b")), "'b': negative mass"),
    (robot(link("a"), link("b", inertia='<inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="-1"/>'),
           joint("j", "a", "b")), "'b': inertia is not positive semidefinite"),
    (robot(link("a"), link("b", inertia='<inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="3"/>'),
           joint("j", "a", "b")), "'b': inertia violates the triangle inequality"),
    (robot(link("a"), link("b", mass="nan"), joint("j", "a", "b")), "'b' mass: non-finite"),
    (robot(link("a"), link("b", inertia='<inertia ixx="inf" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/>'),
           joint("j", "a", "b")), "'b' inertia: non-finite"),
    (robot(link("a"), link("b", mass="heavy"), joint("j", "a", "b")), "link 'b'"),
    (robot(link("a"), link("b", inertia='<inertia ixx="1" iyy="1" izz="1"/>'), joint("j", "a", "b")),
     "'b': <inertia> is missing"),
    (robot(link("a"), link("b"), joint("j", "a", "b").replace('<axis xyz="0 0 1"/>', '<axis xyz="0 0 0"/>')),
     "'j': joint axis is zero"),
    (robot(link("a"), link("b"), joint("j", "a", "b", extra='<origin xyz="0 nan 0"/>')), "joint 'j' origin"),
    (robot(link("a"), link("b"), joint("j", "a", "b", extra='<limit lower="nan" upper="1" effort="1" velocity="1"/>')),
     "'j': limit lower/upper is not a number"),
    (robot(link("a"), '<link name="b"><inertial><mass valu="1"/></inertial></link>', joint("j", "a", "b")),
     "'b': <mass> has no value"),
    (robot(link("a"), link("b"), joint("j", "a", "b", extra='<dynamics damping="-2"/>')), "'j': dynamics damping"),
    (robot(link("a"), link("b"), joint("j", "a", "b", "planar").replace("0 0 1", "0 0 0")),
     "'j': joint axis is zero (a planar joint's axis is the normal of its plane)"),
    (robot(link("a"), link("b"), joint("j", "a", "b", "ball")), "'j': unknown type 'ball'"),
    (robot(link("a"), link("a")), "'a' is defined twice"),
    (robot(link("a"), link("b"), '<joint name="j" type="fixed"><child link="b"/></joint>'), "'j': missing <parent"),
    ("<robot name='x'><link name='a'>", "not well-formed"),
    ("", "neither URDF text nor an existing file"),
])
def test_refusals_name_the_culprit(text, culprit):
    with pytest.raises(URDFError) as err:
        dynamics.load_urdf(text)
    assert culprit in str(err.value)
    assert isinstance(err.value, ValueError)


def test_slightly_off_inertia_warns_instead_of_refusing():
    off = '<inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="2.001"/>'  # 0.05 % over I1 + I2
    model = dynamics.load_urdf(robot(link("a"), link("b", inertia=off), joint("j", "a", "b")))
    assert any("'b'" in w and "triangle" in w for w in model.warnings)
    very_off = '<inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="3"/>'
    lenient = dynamics.load_urdf(robot(link("a"), link("b", inertia=very_off), joint("j", "a", "b")),
                                 strict_inertia=False)
    assert any("'b'" in w for w in lenient.warnings)


# -- untrusted XML ----------------------------------------------------------------------------------

BILLION_LAUGHS = """<?xml version="1.0"?>
<!DOCTYPE lolz [<!ENTITY lol "lol"><!ENTITY lol2 "&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;">
<!ENTITY lol3 "&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;">]>
<robot name="&lol3;"><link name="a"/></robot>"""


def test_billion_laughs_is_refused_quickly():
    t = time.perf_counter()
    with pytest.raises(URDFError, match="DOCTYPE"):
        dynamics.load_urdf(BILLION_LAUGHS)
    assert time.perf_counter() - t < 1.0


def test_external_entity_is_never_read(tmp_path):
    secret = tmp_path / "secret.txt"
    secret.write_text("TOPSECRET")
    text = (f'<?xml version="1.0"?><!DOCTYPE r [<!ENTITY x SYSTEM "file://{secret}">]>'
            f'<robot name="&x;"><link name="a"/></robot>')
    with pytest.raises(URDFError) as err:
        dynamics.load_urdf(text)
    assert "TOPSECRET" not in str(err.value)


def test_files_named_in_the_urdf_are_never_opened(tmp_path, monkeypatch):
    """Meshes are not loaded: dozens of missing mesh files cost nothing and open nothing."""
    visuals = "".join(f'<visual><geometry><mesh filename="package://nowhere/mesh{i}.stl"/></geometry></visual>'
                      f'<collision><geometry><mesh filename="/does/not/exist{i}.dae"/></geometry></collision>'
                      for i in range(40))
    text = robot(f'<link name="a">{visuals}</link>', link("b"), joint("j", "a", "b"))
    opened = []
    real_open = open
    monkeypatch.setattr("builtins.open", lambda f, *a, **k: opened.append(f) or real_open(f, *a, **k))
    model = dynamics.load_urdf(text)
    assert model.nv == 1 and opened == []
    assert model.summary()["meshes_loaded"] == 0


def test_loading_panda_skips_meshes_and_is_fast():
    t = time.perf_counter()
    for _ in range(5):
        dynamics.load_urdf(erd("panda_description/urdf/panda.urdf"))
    # a generous bound (yourdfpy with meshes takes ~0.5 s); the real figure is in the benchmarks
    assert (time.perf_counter() - t) / 5 < 0.1


# -- what is honoured -------------------------------------------------------------------------------

def test_fixed_joints_merge_mass_com_and_inertia_exactly():
    """A body split in two links welded by a rotated fixed joint equals the same body in one link."""
    rng = np.random.default_rng(0)
    from robots import random_inertia
    I1, I2 = random_inertia(rng), random_inertia(rng)
    m1, m2 = 2.0, 3.0
    c1, c2 = np.array([0.1, 0.2, -0.1]), np.array([0.3, -0.1, 0.2])
    rpy2 = np.array([0.3, -0.7, 1.1])
    weld_xyz, weld_rpy = np.array([0.5, 0.1, 0.0]), np.array([0.2, 0.4, -0.5])

    def inertia_xml(I):
        return (f'<inertia ixx="{float(I[0,0])!r}" ixy="{float(I[0,1])!r}" ixz="{float(I[0,2])!r}" iyy="{float(I[1,1])!r}" iyz="{float(I[1,2])!r}" '
                f'izz="{float(I[2,2])!r}"/>')

    fmt = lambda x: " ".join(repr(float(v)) for v in x)  # noqa: E731
    split = robot(link("base"),
                  link("a", m1, inertia_xml(I1), f'<origin xyz="{fmt(c1)}"/>'),
                  link("b", m2, inertia_xml(I2), f'<origin xyz="{fmt(c2)}" rpy="{fmt(rpy2)}"/>'),
                  joint("j", "base", "a"),
                  joint("weld", "a", "b", "fixed", f'<origin xyz="{fmt(weld_xyz)}" rpy="{fmt(weld_rpy)}"/>'))
    model = dynamics.load_urdf(split)
    assert model.nbodies == 1 and model.info["fixed_joints_merged"] == ["weld"]
    # the reference: textbook composition of the two inertias in a's frame
    from dynamics.spatial import rpy_to_matrix
    Rw = rpy_to_matrix(weld_rpy)
    R2 = Rw @ rpy_to_matrix(rpy2)
    c2a = weld_xyz + Rw @ c2
    m = m1 + m2
    c = (m1 * c1 + m2 * c2a) / m

    def shift(I, mass, d):
        return I + mass * (d @ d * np.eye(3) - np.outer(d, d))

    Ic = shift(I1, m1, c1 - c) + shift(R2 @ I2 @ R2.T, m2, c2a - c)
    assert model.masses[0] == pytest.approx(m)
    np.testing.assert_allclose(model.coms[0], c, atol=1e-14)
    np.testing.assert_allclose(model.inertias[0], Ic, atol=1e-14)
    body, T = model.frames["b"]
    assert body == 0
    np.testing.assert_allclose(T[:3, 3], weld_xyz, atol=1e-15)


def test_inertial_rpy_rotates_the_inertia():
    I = '<inertia ixx="1" ixy="0" ixz="0" iyy="2" iyz="0" izz="2.5"/>'
    a = dynamics.load_urdf(robot(link("w"), link("b", 1.0, I, '<origin rpy="0 0 1.5707963267948966"/>'),
                                 joint("j", "w", "b")))
    np.testing.assert_allclose(np.diag(a.inertias[0]), [2, 1, 2.5], atol=1e-12)


def test_joint_order_is_depth_first_in_document_order_and_parents_precede():
    text = robot(link("base"), link("a"), link("a1"), link("b"), link("b1"), link("a2"),
                 joint("jb", "base", "b"), joint("ja", "base", "a"), joint("ja1", "a", "a1"),
                 joint("jb1", "b", "b1"), joint("ja2", "a1", "a2"))
    model = dynamics.load_urdf(text)
    assert model.joint_names == ("jb", "jb1", "ja", "ja1", "ja2")
    assert all(p < i for i, p in enumerate(model.parents))
    assert list(model.parents) == [-1, 0, -1, 2, 3]


def test_limits_damping_friction_continuous_and_mimic():
    text = robot(link("base"), link("a"), link("b"), link("c"),
                 joint("j1", "base", "a", extra='<limit lower="-1" upper="2" effort="30" velocity="4"/>'
                                                 '<dynamics damping="0.5" friction="0.25"/>'),
                 joint("j2", "a", "b", "continuous"),
                 joint("j3", "b", "c", "prismatic", '<limit lower="0" upper="0.3" effort="100" velocity="1"/>'
                                                   '<mimic joint="j1" multiplier="2"/>'))
    model = dynamics.load_urdf(text)
    assert model.nq == model.nv == 3
    assert model.joint_types == ("revolute", "continuous", "prismatic")
    np.testing.assert_array_equal(model.lower, [-1, -np.inf, 0])
    np.testing.assert_array_equal(model.upper, [2, np.inf, 0.3])
    np.testing.assert_array_equal(model.effort_limit, [30, np.inf, 100])
    np.testing.assert_array_equal(model.velocity_limit, [4, np.inf, 1])
    np.testing.assert_array_equal(model.damping, [0.5, 0, 0])
    np.testing.assert_array_equal(model.friction, [0.25, 0, 0])
    assert model.constraints == (dynamics.JointCoupling("j3", "j1", 2.0, 0.0),)  # mimic="coupling" by default
    assert not any("mimic" in w for w in model.warnings)
    free = dynamics.load_urdf(text, mimic="independent")
    assert free.constraints == () and any("'j3' mimics 'j1'" in w for w in free.warnings)
    with pytest.raises(ValueError):
        model.damping[0] = 1.0  # immutable


def test_urdf_floating_joint_at_root_equals_floating_base_option():
    body = link("base", 3.0) + link("arm") + joint("j", "base", "arm")
    a = dynamics.load_urdf(robot(link("world"), body, '<joint name="float" type="floating"><parent link="world"/>'
                                                      '<child link="base"/></joint>'))
    b = dynamics.load_urdf(robot(body), floating_base=True)
    assert a.nq == b.nq == 8 and a.nv == b.nv == 7 and a.floating_base and b.floating_base
    q = np.array([0.1, 0.2, 0.3, 0.1, 0.2, 0.3, 0.9, 0.4])
    q[3:7] /= np.linalg.norm(q[3:7])
    v = np.arange(7.0)
    np.testing.assert_allclose(dynamics.inverse_dynamics(a, q, v, v), dynamics.inverse_dynamics(b, q, v, v))
    with pytest.raises(URDFError, match="already has a floating joint"):
        dynamics.load_urdf(robot(link("world"), body, '<joint name="float" type="floating"><parent link="world"/>'
                                                      '<child link="base"/></joint>'), floating_base=True)


def test_source_may_be_path_str_or_bytes(tmp_path):
    text = robot(link("a"), link("b"), joint("j", "a", "b"))
    p = tmp_path / "r.urdf"
    p.write_text(text)
    for src in (str(p), p, text, text.encode()):
        assert dynamics.load_urdf(src).nv == 1


# -- inputs are checked at the entry ----------------------------------------------------------------

@pytest.fixture(scope="module")
def panda():
    return dynamics.load_urdf(erd("panda_description/urdf/panda.urdf"))


@pytest.mark.parametrize("call, message", [
    (lambda m: dynamics.inverse_dynamics(m, np.zeros(8), np.zeros(9), np.zeros(9)), "q: expected shape (9,) or (B, 9), got (8,)"),
    (lambda m: dynamics.inverse_dynamics(m, np.zeros(9), np.zeros((3, 9)), np.zeros((4, 9))), "a: expected a batch of 3 (or one state), got 4"),
    (lambda m: dynamics.inverse_dynamics(m, np.zeros(9), [np.nan] * 9, np.zeros(9)), "v: contains non-finite"),
    (lambda m: dynamics.inverse_dynamics(m, np.zeros(9), np.zeros(9), np.zeros(9), gravity=[0, 0]), "gravity: expected shape (3,)"),
    (lambda m: dynamics.inverse_dynamics(m, np.zeros(9), np.zeros(9), np.zeros(9), f_ext=np.zeros((3, 6))), "f_ext: expected shape (9, 6)"),
    (lambda m: dynamics.mass_matrix(m, "abc"), "q: expected an array of real numbers"),
    (lambda m: dynamics.forward_dynamics(m, np.zeros((2, 9)), np.zeros(9), np.zeros((2, 8))), "tau: expected shape (9,) or (B, 9), got (2, 8)"),
    (lambda m: dynamics.kinetic_energy(m, np.zeros(9), np.full(9, np.inf)), "v: contains non-finite"),
    (lambda m: dynamics.mass_matrix("panda", np.zeros(9)), "model: expected a dynamics.Model"),
    (lambda m: dynamics.mass_matrix(m, np.zeros(9) + 1j), "q: expected an array of real numbers"),
    (lambda m: dynamics.inverse_dynamics(m, np.zeros(9), np.zeros(9, bool), np.zeros(9)), "v: expected an array of real numbers"),
    (lambda m: dynamics.inverse_dynamics(m, np.zeros(9), [[1, 2], [3]], np.zeros(9)), "v: expected an array of real numbers"),
])
def test_bad_arguments_name_the_argument(panda, call, message):
    with pytest.raises(dynamics.InputError) as err:
        call(panda)
    assert message in str(err.value)


def test_zero_quaternion_is_refused():
    model = dynamics.load_urdf(robot(link("a")), floating_base=True)
    with pytest.raises(dynamics.InputError, match="quaternion"):
        dynamics.mass_matrix(model, np.zeros(7))


def test_massless_joint_is_a_clear_error_for_forward_dynamics():
    model = dynamics.load_urdf(robot(link("a"), link("b", mass=0, inertia=""), link("c"),
                                     joint("j1", "a", "c"), joint("j2", "a", "b")))
    assert model.info["massless_bodies"] == ["b"]
    with pytest.raises(dynamics.InputError, match="singular at joint 'j2'"):
        dynamics.forward_dynamics(model, np.zeros(2), np.zeros(2), np.zeros(2))
