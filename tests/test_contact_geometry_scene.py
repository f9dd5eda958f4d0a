"""Contact geometry of models: URDF collisions (against yourdfpy), the <contact_geometry> extension, scene
building and pair filtering, bad input, the broad phase on a quadruped, and free bodies (against Pinocchio)."""


import numpy as np
import pickle
import pytest
import yourdfpy

import dynamics
from dynamics import Box, Capsule, ContactPoint, Cylinder, Ground, HalfSpace, InputError, Sphere, URDFError
from dynamics.contact.narrow_phase import find_contacts, scene_poses
from dynamics.contact.scene import MAX_PER_PAIR, build_scene
from tests.robots import erd


def body_poses(model, q):
    """4x4 world pose of each body (its frame's placement), then the world's (identity) last."""
    T = np.tile(np.eye(4), (model.nbodies + 1, 1, 1))
    for i, name in enumerate(model.body_names):
        T[i] = dynamics.frame_placement(model, q, name)
    return T


def broad_phase(scene, P):
    """The pairs whose bounding volumes overlap at the geometries' world poses P (scene_poses): bounding spheres
    about each geometry's origin, a plane's half-space against the other's sphere (the core's test)."""
    keep = []
    for k, (a, b) in enumerate(zip(scene.pair_a, scene.pair_b)):
        ca = P[a, :3, 3]
        if np.isinf(scene.radius[b]):  # a plane: its z axis is its normal
            n = P[b, :3, 2]
            overlap = n @ ca - n @ P[b, :3, 3] < scene.radius[a]
        else:
            d = ca - P[b, :3, 3]
            overlap = d @ d < (scene.radius[a] + scene.radius[b]) ** 2
        if overlap:
            keep.append(k)
    return keep


@pytest.mark.parametrize("rel, floating", [("go1_description/urdf/go1.urdf", False),
                                           ("panda_description/urdf/panda_collision.urdf", False),
                                           ("anymal_c_simple_description/urdf/anymal.urdf", True)])
def test_urdf_collisions_against_yourdfpy(rel, floating):
    """Every primitive's world pose at a random configuration equals yourdfpy's link pose times the
    collision origin (fixed joints merged on our side, a scene graph on theirs); kinds and sizes agree."""
    path = erd(rel)
    model = dynamics.load_urdf(path, collision=True, floating_base=floating, strict_inertia=False,
                               mimic="independent")
    ref = yourdfpy.URDF.load(path, load_meshes=False, build_collision_scene_graph=False, build_scene_graph=True)
    rng = np.random.default_rng(1)
    q = model.neutral()
    cfg = {}
    for j in ref.actuated_joint_names:
        if j in model.joint_names:
            q[model.q_slice(j)] = cfg[j] = rng.uniform(-1, 1)
    for j in model.joint_names:  # yourdfpy moves mimic joints with their leader
        mimic = ref.joint_map[j].mimic if j in ref.joint_map else None
        if mimic is not None:
            q[model.q_slice(j)] = mimic.multiplier * cfg[mimic.joint] + mimic.offset
    ref.update_cfg(cfg)
    poses = body_poses(model, q)
    want = []
    for link in ref.link_map.values():
        for k, c in enumerate(link.collisions):
            g = c.geometry
            if g.mesh is not None:
                continue
            kind = "sphere" if g.sphere else "box" if g.box else "cylinder" if g.cylinder else "capsule"
            size = (g.sphere.radius, 0, 0) if g.sphere else tuple(g.box.size) if g.box else \
                (getattr(g, kind).radius, getattr(g, kind).length, 0)
            T = ref.get_transform(link.name, ref.base_link) @ (np.eye(4) if c.origin is None else c.origin)
            want.append((link.name, kind, size, T))
    got = model.collision_geometry
    assert len(got) == len(want) == model.info["collision_primitives"]
    meshes = sum(c.geometry.mesh is not None for l in ref.link_map.values() for c in l.collisions)
    assert model.info["collision_meshes_skipped"] == meshes
    for g, (link, kind, size, T) in zip(got, want):
        assert (g.frame, g.kind) == (link, kind)
        np.testing.assert_allclose(g.size, size, rtol=1e-15)
        assert not g.pose.flags.writeable
        np.testing.assert_allclose(poses[g.body] @ g.pose, T, atol=1e-12)
    drawn = scene_poses(model, build_scene(model, world=[]), q)  # what an inspector draws
    np.testing.assert_allclose(drawn, [T for *_, T in want], atol=1e-12)


URDF = """<robot name="toy">
  <link name="world"><collision><geometry><box size="2 2 0.1"/></geometry></collision></link>
  <link name="a"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision name="a_ball"><origin xyz="0 0 0.5"/><geometry><sphere radius="0.1"/></geometry></collision>
    <collision><geometry><mesh filename="package://nowhere/a.stl"/></geometry></collision></link>
  <link name="a_tip">
    <collision><origin xyz="0.1 0 0" rpy="0 1.5707963267948966 0"/>
      <geometry><capsule radius="0.02" length="0.3"/></geometry></collision></link>
  <link name="b"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0 0.2" rpy="0.3 0 0"/><geometry><cylinder radius="0.05" length="0.4"/></geometry>
    </collision></link>
  <joint name="j1" type="revolute"><parent link="world"/><child link="a"/><origin xyz="0 0 1"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="weld" type="fixed"><parent link="a"/><child link="a_tip"/><origin xyz="0 0 1" rpy="0 0 0.5"/></joint>
  <joint name="j2" type="revolute"><parent link="a_tip"/><child link="b"/><origin xyz="0 0 0.2"/>
    <axis xyz="1 0 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <contact_geometry link="b" type="box" size="0.1 0.2 0.3" xyz="0 0 0.4" rpy="0 0 0.2" name="b_sole"/>
  <contact_geometry link="a_tip" type="point" xyz="0.4 0 0"/>
</robot>"""


def rpy(r, p, y):
    from dynamics.spatial import rpy_to_matrix
    T = np.eye(4)
    T[:3, :3] = rpy_to_matrix([r, p, y])
    return T


def shift(x, y, z):
    T = np.eye(4)
    T[:3, 3] = (x, y, z)
    return T


def test_urdf_written_by_hand():
    model = dynamics.load_urdf(URDF, collision=True)
    plain = dynamics.load_urdf(URDF)
    assert plain.collision_geometry == () and "collision_primitives" not in plain.info
    g = {x.name: x for x in model.collision_geometry}
    assert list(g) == ["world/collision0", "a_ball", "a_tip/collision0", "b/collision0", "b_sole",
                       "contact_geometry1"]
    assert model.info["collision_meshes_skipped"] == 1 and model.info["collision_primitives"] == 6
    assert (g["world/collision0"].body, g["world/collision0"].kind, g["world/collision0"].size) == (-1, "box",
                                                                                                    (2, 2, 0.1))
    assert (g["a_ball"].body, g["a_ball"].size) == (0, (0.1, 0, 0))
    np.testing.assert_allclose(g["a_ball"].pose, shift(0, 0, 0.5))
    # a_tip is welded to a: its pose in body a is the fixed joint's origin composed with the collision origin
    tip = g["a_tip/collision0"]
    assert (tip.body, tip.frame, tip.kind, tip.size) == (0, "a_tip", "capsule", (0.02, 0.3, 0))
    np.testing.assert_allclose(tip.pose, shift(0, 0, 1) @ rpy(0, 0, 0.5) @ shift(0.1, 0, 0) @ rpy(0, np.pi / 2, 0),
                               atol=1e-15)
    np.testing.assert_allclose(g["b_sole"].pose, shift(0, 0, 0.4) @ rpy(0, 0, 0.2), atol=1e-15)
    assert (g["b_sole"].body, g["b_sole"].size) == (1, (0.1, 0.2, 0.3))
    pt = g["contact_geometry1"]
    assert (pt.body, pt.kind, pt.size) == (0, "point", (0, 0, 0))
    np.testing.assert_allclose(pt.pose, shift(0, 0, 1) @ rpy(0, 0, 0.5) @ shift(0.4, 0, 0), atol=1e-15)
    # pickling (process pools) keeps the poses read-only
    again = pickle.loads(pickle.dumps(model))
    assert all(not x.pose.flags.writeable for x in again.collision_geometry)
    assert [x.name for x in again.collision_geometry] == list(g)


@pytest.mark.parametrize("element, message", [
    ('<contact_geometry link="nope" type="sphere" radius="0.1"/>', "link='nope'"),
    ('<contact_geometry link="a" type="cone" radius="0.1"/>', "type 'cone'"),
    ('<contact_geometry link="a" type="sphere" radius="-0.1"/>', ">= 0"),
    ('<contact_geometry link="a" type="box" size="1 nan 1"/>', "size"),
    ('<contact_geometry link="a" type="capsule" radius="0.1"/>', "length"),
])
def test_urdf_bad_contact_geometry(element, message):
    with pytest.raises(URDFError, match=message):
        dynamics.load_urdf(URDF.replace("</robot>", element + "</robot>"), collision=True)
    dynamics.load_urdf(URDF.replace("</robot>", element + "</robot>"))  # not read without collision=True


def test_urdf_bad_collision_size():
    bad = URDF.replace('<sphere radius="0.1"/>', '<sphere radius="-1"/>')
    with pytest.raises(URDFError, match="link 'a' <collision> 0"):
        dynamics.load_urdf(bad, collision=True)


# -- scenes and pair filtering ----------------------------------------------------------------------------

def chain(n=4):
    """A planar chain of n links along x, a sphere on each."""
    links = "".join(f'<link name="l{i}"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" '
                    f'ixz="0" iyz="0"/></inertial><collision><origin xyz="0.5 0 0"/><geometry><sphere '
                    f'radius="0.1"/></geometry></collision></link>' for i in range(n))
    joints = "".join(f'<joint name="j{i}" type="continuous"><parent link="{"base" if i == 0 else f"l{i - 1}"}"/>'
                     f'<child link="l{i}"/><origin xyz="{0 if i == 0 else 1} 0 1"/><axis xyz="0 0 1"/></joint>'
                     for i in range(n))
    return dynamics.load_urdf(f'<robot name="chain"><link name="base"/>{links}{joints}</robot>', collision=True)


def pairs_of(scene):
    return {frozenset((scene.names[a], scene.names[b])) for a, b in zip(scene.pair_a, scene.pair_b)}


def test_pair_filtering():
    model = chain(4)
    names = [g.name for g in model.collision_geometry]
    s = build_scene(model)
    assert pairs_of(s) == {frozenset((n, "ground")) for n in names}
    assert s.max_contacts == 4 and s.kind.tolist() == [0, 0, 0, 0, 5] and np.isinf(s.radius[-1])
    s = build_scene(model, self_collision=True)  # not a body with its parent
    self_pairs = pairs_of(s) - {frozenset((n, "ground")) for n in names}
    assert self_pairs == {frozenset((names[i], names[j])) for i in range(4) for j in range(i + 2, 4)}
    s = build_scene(model, self_collision=True, exclude=[("l0", "l2"), ("l3", "world")])
    assert frozenset((names[0], names[2])) not in pairs_of(s)
    assert frozenset((names[3], "ground")) not in pairs_of(s) and len(pairs_of(s)) == 3 + 2
    s = build_scene(model, pairs=[("l0", "l1"), ("l3", "ground")])
    assert pairs_of(s) == {frozenset((names[0], names[1])), frozenset((names[3], "ground"))}
    # pairs are kept ordered by kind (a plane is always b)
    s = build_scene(model, [Box("l1", (0.1, 0.1, 0.1)), Sphere("l3", 0.1)], world=[HalfSpace((1, 0, 0), 2.0)])
    assert all(s.kind[a] <= s.kind[b] for a, b in zip(s.pair_a, s.pair_b))
    assert s.max_contacts == MAX_PER_PAIR[4, 5] + MAX_PER_PAIR[0, 5] == 9
    for a in s.arrays:
        assert not a.flags.writeable


def test_free_bodies_pair_with_the_robot_without_self_collision():
    model = dynamics.add_free_body(chain(3), "box", Box("box", (0.2, 0.2, 0.2)), 1.0)
    model = dynamics.add_free_body(model, "ball", Sphere("ball", 0.1), 1.0)
    s = build_scene(model, world=[])
    links = [g.name for g in model.collision_geometry[:3]]
    assert pairs_of(s) == {frozenset((x, y)) for x in links for y in ("box/box", "ball/sphere")} | \
        {frozenset(("box/box", "ball/sphere"))}


@pytest.mark.parametrize("call, message", [
    (lambda m: build_scene(m, [Sphere("l9", 0.1)]),
     "geometries\\[0\\].frame: no frame named 'l9'; closest: \\['l1', 'l0'"),
    (lambda m: build_scene(m, exclude=[("l0", "l7x")]), "exclude\\[0\\]"),
    (lambda m: build_scene(m, pairs=[("l0",)]), "pairs\\[0\\]"),
    (lambda m: build_scene(m, pairs=(("l0", "l1") for _ in range(10 ** 6))), "100000"),
    (lambda m: build_scene(m, pairs=[("l0", "l1")] * 10 ** 6), "1000000 entries"),
    (lambda m: build_scene(m, world=[Sphere("l0", 0.1)]), "world\\[0\\]"),
    (lambda m: build_scene(m, [Sphere("l0", 0.1)] * 10_001), "at most 10000"),
    (lambda m: build_scene(m, [Sphere("l0", 0.1)] * 2000, pairs=[("l0", "l0")]), "match more than"),
    (lambda m: build_scene(m, [Sphere("l0", 0.1)] * 5000, self_collision=True), "self_collision"),
    (lambda m: build_scene(m, [Sphere("l0", 0.1)] * 5000, world=[Ground(height=-k) for k in range(30)]),
     "150000 candidate pairs"),
    (lambda m: build_scene(m, ["l0"]), "geometries\\[0\\]"),
    (lambda m: build_scene(m, self_collision="yes"), "self_collision"),
    (lambda m: Sphere("l0", -0.1), "Sphere.radius"),
    (lambda m: Sphere("l0", float("nan")), "Sphere.radius"),
    (lambda m: Box("l0", (0.1, -1, 0.1)), "Box.size"),
    (lambda m: Box("l0", (0.1, 0.1, 0.1), pose=np.full((4, 4), np.nan)), "Box.pose"),
    (lambda m: Box("l0", (0.1, 0.1, 0.1), pose=2 * np.eye(4)), "Box.pose"),
    (lambda m: Capsule("l0", 0.1, -0.2), "Capsule.length"),
    (lambda m: Cylinder(3, 0.1, 0.2), "Cylinder.frame"),
    (lambda m: ContactPoint("l0", (0, 0)), "ContactPoint.point"),
    (lambda m: Ground(normal=(0, 0, 0)), "Ground.normal"),
    (lambda m: Ground(height=float("inf")), "Ground.height"),
    (lambda m: HalfSpace((1, 0, float("nan")), 0.0), "HalfSpace.normal"),
    (lambda m: dynamics.add_free_body(m, "l0", Sphere("l0", 0.1), 1.0), "already has"),
    (lambda m: dynamics.add_free_body(m, "ball", Sphere("x", 0.1), 1.0), "geometry.frame"),
    (lambda m: dynamics.add_free_body(m, "ball", Sphere("ball", 0.1), -1.0), "mass"),
    (lambda m: dynamics.add_free_body(m, "ball", ContactPoint("ball", (0, 0, 0)), 1.0), "geometry"),
    (lambda m: dynamics.add_free_body(m, "ball", Sphere("ball", 0.1), 1.0, inertia=np.diag([1, 1, 3])),
     "triangle"),
])
def test_bad_input_names_the_field(call, message):
    with pytest.raises(InputError, match=message):
        call(chain(2))


def test_ground_normal_is_normalised_and_a_point_touches_it():
    assert Ground(normal=(0, 0, 3)).normal == (0.0, 0.0, 1.0)
    g = Ground(normal=(1, 0, 1), height=0.5)
    np.testing.assert_allclose(g.normal, np.array([1, 0, 1]) / np.sqrt(2), rtol=1e-15)


# -- broad phase -----------------------------------------------------------------------------------------

def test_broad_phase_on_a_standing_quadruped():
    """Go1 standing (its feet 1 mm into the ground): with its 4 foot spheres alone the narrow phase sees the 4
    foot-ground pairs; with every primitive of its URDF (38 pairs) still only a few, and the contacts are the
    feet's."""
    model = dynamics.load_urdf(erd("go1_description/urdf/go1.urdf"), collision=True, floating_base=True,
                               strict_inertia=False)
    q = model.neutral()
    for leg in ("FR", "FL", "RR", "RL"):
        q[model.q_slice(f"{leg}_thigh_joint")], q[model.q_slice(f"{leg}_calf_joint")] = 0.8, -1.6
    T = body_poses(model, q)
    feet = [g for g in model.collision_geometry if g.frame.endswith("_foot")]
    assert len(feet) == 4 and all(g.kind == "sphere" for g in feet)
    lowest = min((T[g.body, :3, :3] @ g.pose[:3, 3] + T[g.body, :3, 3])[2] - g.size[0] for g in feet)
    q[2] = -lowest - 1e-3
    for geoms, npairs, examined in ((feet, 4, 4), (None, 38, 8)):
        s = build_scene(model, geoms)
        keep = broad_phase(s, scene_poses(model, s, q))
        # with every primitive: the feet and the lower legs, whose bounding spheres reach the ground
        assert (s.npairs, len(keep)) == (npairs, examined)
        parts = {s.names[s.pair_a[k]].split("/")[0].split("_")[1] for k in keep}
        assert parts == ({"foot"} if geoms else {"foot", "calf"})
        c = find_contacts(model, s, q)
        assert len(c.depth) == 4 and set(c.a) == {g.name for g in feet}
        np.testing.assert_allclose(c.normal, np.tile([0, 0, 1], (4, 1)))
        assert c.depth.max() == pytest.approx(1e-3, rel=1e-9)
    assert build_scene(model).npairs == 38


# -- free bodies -----------------------------------------------------------------------------------------

def pin_free_body(mass, com, Ic):
    import pinocchio as pin
    m = pin.Model()
    j = m.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "free")
    m.appendBodyToJoint(j, pin.Inertia(mass, np.asarray(com, float), np.asarray(Ic, float)), pin.SE3.Identity())
    m.gravity.linear = np.array([0, 0, -9.81])
    return m


@pytest.mark.parametrize("geometry, inertia", [
    (Box("obj", (0.3, 0.2, 0.1), pose=np.array([[0, -1, 0, 0.05], [1, 0, 0, 0.0], [0, 0, 1, -0.02], [0, 0, 0, 1]])),
     lambda m: m / 12 * np.diag([0.2 ** 2 + 0.1 ** 2, 0.3 ** 2 + 0.1 ** 2, 0.3 ** 2 + 0.2 ** 2])),
    (Sphere("obj", 0.1, offset=(0.0, 0.02, 0.0)), lambda m: 0.4 * m * 0.01 * np.eye(3)),
    (Cylinder("obj", 0.05, 0.3), lambda m: np.diag([m * (3 * 0.05 ** 2 + 0.09) / 12] * 2 + [m * 0.05 ** 2 / 2])),
    (Capsule("obj", 0.05, 0.3), None),
])
def test_free_body_against_pinocchio(geometry, inertia):
    """planar_2r plus a free solid: the robot's inverse dynamics unchanged, the solid's equal to Pinocchio's free
    flyer with the closed-form inertia of the solid (uniform density) at its centre (at a random a, which pins
    both M and the bias forces; CRBA and ABA are checked in the slow test below)."""
    import pinocchio as pin
    mass = 1.7
    robot = dynamics.load_urdf("planar_2r")
    model = dynamics.add_free_body(robot, "obj", geometry, mass)
    assert model.nq == robot.nq + 7 and model.nv == robot.nv + 6 and model.floating_base
    assert model.collision_geometry[-1].body == robot.nbodies and model.collision_geometry[-1].frame == "obj"
    T = geometry.pose
    if inertia is None:  # the capsule: a cylinder and two hemispheres of one density, by their volumes
        r, L = 0.05, 0.3
        mc, mh = mass * L / (L + 4 * r / 3), mass * (4 * r / 3) / (L + 4 * r / 3)
        zh = L / 2 + 3 * r / 8  # a hemisphere's centre of mass from the capsule's centre
        Ih = 2 * r * r / 5 - (3 * r / 8) ** 2  # per unit mass, about its own centre of mass, across the axis
        lateral = mc * (3 * r * r + L * L) / 12 + mh * (Ih + zh ** 2)
        Ic = np.diag([lateral, lateral, (mc / 2 + 2 * mh / 5) * r * r])
    else:
        Ic = inertia(mass)
    Ic = T[:3, :3] @ Ic @ T[:3, :3].T
    ref = pin_free_body(mass, T[:3, 3], Ic)
    data = ref.createData()
    rng = np.random.default_rng(3)
    q, v, a = model.neutral(), rng.normal(size=model.nv), rng.normal(size=model.nv)
    q[robot.nq:robot.nq + 3] = rng.normal(size=3)
    quat = rng.normal(size=4)
    q[robot.nq + 3:] = quat / np.linalg.norm(quat)
    qb, vb, ab = q[robot.nq:], v[robot.nv:], a[robot.nv:]
    tau = dynamics.inverse_dynamics(model, q, v, a)
    np.testing.assert_allclose(tau[:robot.nv], dynamics.inverse_dynamics(robot, q[:robot.nq], v[:robot.nv],
                                                                          a[:robot.nv]), rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(tau[robot.nv:], pin.rnea(ref, data, qb, vb, ab), rtol=1e-12, atol=1e-12)


@pytest.mark.slow  # forward dynamics and CRBA on a floating model compile for ~50 s from an empty cache
def test_free_body_forward_dynamics_inverts_inverse_dynamics():
    """ABA(RNEA(a)) = a on a robot with two free bodies (two roots on free joints beside a fixed-base arm), and
    CRBA's M a = RNEA(a) - RNEA(0) with the bodies uncoupled from the arm."""
    model = dynamics.add_free_body(dynamics.load_urdf("planar_2r"), "obj", Capsule("obj", 0.05, 0.3), 1.7)
    model = dynamics.add_free_body(model, "ball", Sphere("ball", 0.1, offset=(0.01, 0.0, 0.02)), 0.3)
    rng = np.random.default_rng(4)
    q, v, a = model.neutral(), rng.normal(size=model.nv), rng.normal(size=model.nv)
    for k in model.quaternion_starts:
        quat = rng.normal(size=4)
        q[k:k + 4] = quat / np.linalg.norm(quat)
    tau = dynamics.inverse_dynamics(model, q, v, a)
    np.testing.assert_allclose(dynamics.forward_dynamics(model, q, v, tau), a, rtol=1e-10, atol=1e-10)
    M = dynamics.mass_matrix(model, q)
    np.testing.assert_allclose(M @ a, tau - dynamics.inverse_dynamics(model, q, v, 0 * a), rtol=1e-10, atol=1e-10)
    assert not M[:2, 2:].any() and not M[2:8, 8:].any()


def test_urdf_floating_link_is_a_free_body():
    """A URDF link on a floating joint (a box beside an arm) is a tree of its own: paired with the arm without
    self-collision; find_contacts at a configuration gives the box's face on the ground."""
    urdf = """<robot name="r"><link name="world"/>
    <link name="arm"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial>
      <collision><geometry><capsule radius="0.05" length="0.5"/></geometry></collision></link>
    <link name="box"><inertial><mass value="0.5"/><inertia ixx="1e-3" iyy="1e-3" izz="1e-3" ixy="0" ixz="0" iyz="0"/>
      </inertial><collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>
    <joint name="j" type="revolute"><parent link="world"/><child link="arm"/><origin xyz="0 0 1"/>
      <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
    <joint name="box_free" type="floating"><parent link="world"/><child link="box"/></joint></robot>"""
    model = dynamics.load_urdf(urdf, collision=True)
    s = build_scene(model)
    assert pairs_of(s) == {frozenset(p) for p in (("arm/collision0", "box/collision0"),
                                                  ("arm/collision0", "ground"), ("box/collision0", "ground"))}
    q = model.neutral()
    q[model.q_slice("box_free")] = [0.3, 0.0, 0.049, 0, 0, np.sin(0.2), np.cos(0.2)]  # turned 0.4 rad about z
    c = find_contacts(model, s, q)
    assert c.a == ("box/collision0",) * 4 and c.b == ("ground",) * 4
    np.testing.assert_allclose(c.depth, 0.001, rtol=1e-9)
    np.testing.assert_allclose(np.sort(np.linalg.norm(c.point[:, :2] - [0.3, 0], axis=1)), [np.sqrt(0.005)] * 4)
    with pytest.raises(InputError, match="q"):
        find_contacts(model, s, q[:3])


def test_locked_joints_keep_the_collision_geometry():
    """lock_joints moves each primitive onto the body its body was merged into (the world for a body welded to a
    fixed base): every primitive keeps its world pose at the locked values."""
    model = dynamics.load_urdf(erd("go1_description/urdf/go1.urdf"), collision=True, floating_base=False,
                               strict_inertia=False)
    held = {"FR_hip_joint": 0.2, "FR_thigh_joint": 0.7, "FR_calf_joint": -1.4, "RL_calf_joint": -1.1}
    reduced = dynamics.lock_joints(model, held)
    rng = np.random.default_rng(3)
    q = model.neutral()
    for name in model.joint_names:
        q[model.q_slice(name)] = held.get(name, rng.uniform(-1, 1))
    qr = np.array([q[model.q_slice(n)][0] for n in reduced.joint_names])
    full, red = body_poses(model, q), body_poses(reduced, qr)
    assert len(reduced.collision_geometry) == len(model.collision_geometry)
    welded = 0
    for g, h in zip(model.collision_geometry, reduced.collision_geometry):
        assert (g.name, g.kind, g.size) == (h.name, h.kind, h.size) and not h.pose.flags.writeable
        np.testing.assert_allclose(red[h.body] @ h.pose, full[g.body] @ g.pose, atol=1e-12)
        welded += h.body < 0
    assert welded >= 4  # the front-right leg's hip, thigh, calf and foot now belong to the world
