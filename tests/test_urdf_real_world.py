"""What urdfdom reads, we read (issue: published URDFs refused), and typos that would silently change the
numbers are named.  Each case is generated here from a small arm; the reference is the same arm written
plainly, so a lenient reading must give exactly the same model."""

import time

import numpy as np
import pytest

import dynamics
from dynamics import URDFError

ARM = ('<robot name="arm">'
       '<link name="base"/>'
       '<link name="l1"><inertial><origin xyz="0 0 0.1"/><mass value="2"/>'
       '<inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.05"/></inertial></link>'
       '<link name="l2"><inertial><origin xyz="0.2 0 0"/><mass value="1"/>'
       '<inertia ixx="0.02" ixy="0" ixz="0" iyy="0.03" iyz="0" izz="0.03"/></inertial></link>'
       '<joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>'
       '<limit lower="-2" upper="2" effort="10" velocity="3"/></joint>'
       '<joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="0 0 0.3"/>'
       '<axis xyz="0 1 0"/>{limit2}</joint>'
       '</robot>')
PLAIN = ARM.format(limit2='<limit lower="-1" upper="1" effort="10" velocity="3"/>')


def same_dynamics(a, b):
    rng = np.random.default_rng(0)
    q, v, acc = rng.uniform(-1, 1, (3, 2))
    np.testing.assert_array_equal(dynamics.inverse_dynamics(a, q, v, acc), dynamics.inverse_dynamics(b, q, v, acc))
    np.testing.assert_array_equal(dynamics.mass_matrix(a, q), dynamics.mass_matrix(b, q))


@pytest.mark.parametrize("prefix", [
    '<?xml version="0.0"?>',                        # pybullet's minitaur.urdf, cube_small.urdf, duck_vhacd.urdf
    '\n\n  <?xml version="1.0" encoding="utf-8"?>',  # diff_ring.urdf: blank lines before the declaration
    "<?xml version='2.5' ?>\n",
])
def test_xml_declarations_that_urdfdom_accepts(prefix):
    model = dynamics.load_urdf(prefix + PLAIN)
    same_dynamics(model, dynamics.load_urdf(PLAIN))
    assert model.warnings == ()


def test_doctype_after_a_lenient_declaration_is_still_refused():
    text = '<?xml version="0.0"?><!DOCTYPE r [<!ENTITY x "y">]>' + PLAIN
    with pytest.raises(URDFError, match="DOCTYPE"):
        dynamics.load_urdf(text)


def test_inverted_limits_mean_unlimited_with_a_warning():
    """cube_no_rotation.urdf: lower > upper, which urdfdom loads and simulators read as 'no limit'."""
    model = dynamics.load_urdf(ARM.format(limit2='<limit lower="1" upper="-1" effort="10" velocity="3"/>'))
    assert model.lower[1] == -np.inf and model.upper[1] == np.inf
    assert model.lower[0] == -2 and model.upper[0] == 2
    assert any("'j2'" in w and "unlimited" in w for w in model.warnings)
    same_dynamics(model, dynamics.load_urdf(PLAIN))


INERTIA_L1 = '<inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.05"/>'


@pytest.mark.parametrize("old, new, words", [
    (INERTIA_L1, INERTIA_L1.replace("inertia", "inertai"), ["'l1'", "<inertai>"]),
    (INERTIA_L1, INERTIA_L1.replace("/>", ' izx="3"/>'), ["'l1'", "'izx'"]),
    ('<origin xyz="0 0 0.1"/>', '<orgin xyz="0 0 0.1"/>', ["'l1'", "<orgin>"]),
])
def test_typos_in_inertials_are_named(old, new, words):
    model = dynamics.load_urdf(PLAIN.replace(old, new, 1))
    assert any(all(w in msg for w in words) for msg in model.warnings), model.warnings


def test_a_mass_without_value_is_refused():
    with pytest.raises(URDFError, match=r"'l1': <mass> has no value"):
        dynamics.load_urdf(PLAIN.replace('<mass value="2"/>', '<mass valu="2"/>'))


def test_unknown_joint_attribute_is_named():
    model = dynamics.load_urdf(PLAIN.replace('<limit lower="-1"', '<limit lowr="-1"'))
    assert any("'j2'" in w and "'lowr'" in w for w in model.warnings)


def test_huge_axis_components_give_the_unit_axis():
    text = PLAIN.replace('<axis xyz="0 1 0"/>', '<axis xyz="0 1e300 0"/>')
    same_dynamics(dynamics.load_urdf(text), dynamics.load_urdf(PLAIN))
    diagonal = dynamics.load_urdf(PLAIN.replace('<axis xyz="0 1 0"/>', '<axis xyz="1e300 1e300 1e300"/>'))
    np.testing.assert_allclose(diagonal.axes[1], np.ones(3) / np.sqrt(3), rtol=1e-15)


def test_a_huge_tree_is_refused_quickly_with_a_short_message():
    links = "".join(f'<link name="l{i}"/>' for i in range(100_001))
    t = time.perf_counter()
    with pytest.raises(URDFError) as err:
        dynamics.load_urdf(f'<robot name="big">{links}</robot>')
    assert time.perf_counter() - t < 5.0
    assert "100001 links" in str(err.value) and len(str(err.value)) < 300


def test_many_roots_are_listed_briefly():
    links = "".join(f'<link name="l{i}"/>' for i in range(5000))
    with pytest.raises(URDFError, match="more than one root") as err:
        dynamics.load_urdf(f'<robot name="flat">{links}</robot>')
    assert len(str(err.value)) < 400 and "5000 in all" in str(err.value)


@pytest.mark.parametrize("where", ["robot", "link", "joint"])
def test_absurdly_long_names_are_refused(where):
    long = "x" * 100_000
    text = {"robot": PLAIN.replace('name="arm"', f'name="{long}"'),
            "link": PLAIN.replace('"l2"', f'"{long}"'),
            "joint": PLAIN.replace('"j2"', f'"{long}"')}[where]
    with pytest.raises(URDFError, match=f"{where} name") as err:
        dynamics.load_urdf(text)
    assert len(str(err.value)) < 300
