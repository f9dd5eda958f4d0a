"""The inspector page (GET /inspect) in a real headless browser: Debian's Chromium driven by Selenium through the
system's chromedriver (nothing downloaded: Selenium Manager is told to stay offline).

What the page shows is compared with the library computed here, independently of the page and the service: the
joint names of Panda and Talos, the rendered pose of a link after a slider moved (dynamics.forward_kinematics),
the gravity torques beside the sliders (dynamics.gravity_torques), a simulated trajectory's last frame, the pose
of a robot with every joint type at the model's neutral configuration and after each of its sliders moved. Without
a browser the tests skip, saying why; in CI (CI=true) they fail instead. One browser and one server for the
module.
"""

from __future__ import annotations

import json
import os
import shutil
import time

import httpx
import numpy as np
import pytest

import dynamics
from dynamics.joints import KINDS
from dynamics.spatial import rpy_to_matrix
from robots import erd
from service_fixtures import shared_server

CHROMIUM = ("chromium", "chromium-browser", "google-chrome")
TIMEOUT = 240.0  # s: a page waits for the server, which may be compiling a kernel on a loaded 2-core machine
PANDA = erd("panda_description/urdf/panda.urdf")
TALOS = erd("talos_data/robots/talos_reduced.urdf")
#: every joint type on one robot, uploaded on a floating base (a free joint at its root): a planar cart (its plane
#: the x-y plane, so that its in-plane directions are the joint frame's x and y), a spherical shoulder, an elbow
#: whose limits exclude 0 (its neutral is the middle of its range, not 0) and a prismatic finger
EVERY_JOINT_URDF = """<robot name="every_joint">
  <link name="base"><inertial><mass value="2"/><inertia ixx="0.02" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.03"/>
    </inertial></link>
  <link name="cart"><inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/>
    </inertial></link>
  <link name="arm"><inertial><origin xyz="0 0 0.15"/><mass value="0.8"/>
    <inertia ixx="0.006" ixy="0" ixz="0" iyy="0.006" iyz="0" izz="0.001"/></inertial></link>
  <link name="forearm"><inertial><origin xyz="0.1 0 0"/><mass value="0.5"/>
    <inertia ixx="0.0005" ixy="0" ixz="0" iyy="0.002" iyz="0" izz="0.002"/></inertial></link>
  <link name="finger"><inertial><mass value="0.1"/>
    <inertia ixx="0.0001" ixy="0" ixz="0" iyy="0.0001" iyz="0" izz="0.0001"/></inertial></link>
  <joint name="slide" type="planar"><parent link="base"/><child link="cart"/><origin xyz="0.1 0 0.05"/>
    <axis xyz="0 0 1"/></joint>
  <joint name="shoulder" type="spherical"><parent link="cart"/><child link="arm"/><origin xyz="0 0 0.1"/></joint>
  <joint name="elbow" type="revolute"><parent link="arm"/><child link="forearm"/><origin xyz="0 0 0.3"/>
    <axis xyz="0 1 0"/><limit lower="0.2" upper="2" effort="10" velocity="3"/></joint>
  <joint name="finger" type="prismatic"><parent link="forearm"/><child link="finger"/><origin xyz="0.2 0 0"/>
    <axis xyz="1 0 0"/><limit lower="-0.05" upper="0.05" effort="10" velocity="1"/></joint>
</robot>"""
BAD_URDF = ('<robot name="broken"><link name="a"/><joint name="j" type="revolute"><parent link="a"/>'
            '<child link="missing"/><axis xyz="0 0 1"/></joint></robot>')


def _missing(reason: str):
    if os.environ.get("CI") == "true":
        pytest.fail(f"CI: {reason} (the .ci/run apt step installs chromium and chromium-driver)")
    pytest.skip(reason)


@pytest.fixture(scope="module")
def browser():
    browser_path = next(filter(None, (shutil.which(b) for b in CHROMIUM)), None)
    driver_path = shutil.which("chromedriver")
    if browser_path is None or driver_path is None:
        _missing("no Chromium and chromedriver on PATH (apt-get install chromium chromium-driver)")
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        _missing("selenium is not installed (the test extra)")
    os.environ["SE_OFFLINE"] = "true"  # Selenium Manager: never download a browser or a driver
    options = webdriver.ChromeOptions()
    options.binary_location = browser_path
    for arg in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--window-size=1280,800",
                "--enable-unsafe-swiftshader", "--use-angle=swiftshader", "--disable-gpu-sandbox"):
        options.add_argument(arg)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(options=options, service=Service(driver_path))
    driver.set_script_timeout(TIMEOUT)
    yield driver
    driver.quit()


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    return shared_server(tmp_path_factory.getbasetemp())


def wait_for(driver, script: str, timeout: float = TIMEOUT):
    """Poll a JS expression until it is truthy; its value."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        value = driver.execute_script(f"return {script}")
        if value:
            return value
        time.sleep(0.1)
    status = driver.execute_script("return document.getElementById('status').textContent")
    raise AssertionError(f"timed out waiting for {script}; the page says {status!r}")


def open_page(driver, url: str) -> None:
    driver.get(url)
    wait_for(driver, "window.inspector && window.inspector.ready")


def errors(driver) -> list[str]:
    return [e["message"] for e in driver.get_log("browser") if e["level"] in ("SEVERE", "ERROR")]


def drop(driver, name: str, text: str) -> None:
    """Drop a file on the page's drop zone, as a user dragging it from a file manager."""
    driver.execute_script("""
        const dt = new DataTransfer();
        dt.items.add(new File([arguments[1]], arguments[0], {type: "application/xml"}));
        document.getElementById("drop").dispatchEvent(new DragEvent("drop", {dataTransfer: dt, bubbles: true}));
    """, name, text)


def rendered(driver, link: str) -> np.ndarray:
    """The 4x4 world matrix of a link as drawn (three.js stores it column-major)."""
    return np.array(driver.execute_script("return window.inspector.linkPose(arguments[0])", link)).reshape(4, 4).T


def test_the_page_loads_with_no_console_error(browser, server):
    open_page(browser, server.url + "/inspect/planar_2r")
    assert errors(browser) == []
    assert browser.execute_script("return window.inspector.jointNames()") == ["joint1", "joint2"]
    assert browser.execute_script("return document.querySelectorAll('#viewer canvas').length") == 1
    # the 3D library came from this server, and no request left it
    sources = browser.execute_script("return performance.getEntriesByType('resource').map(e => e.name)")
    assert sources and all(s.startswith(server.url) for s in sources), sources


def test_a_dropped_urdf_shows_every_joint_and_a_slider_moves_the_link(browser, server):
    """Panda dropped on the page (uploaded through the API); its tree; joint 1 moved by its slider: the
    rendered link 7 is where the library's forward kinematics puts it, and g(q) is the library's."""
    with open(PANDA) as f:
        drop(browser, "panda.urdf", f.read())
    wait_for(browser, "document.getElementById('upload-result').textContent.startsWith('stored as')")
    wait_for(browser, "window.inspector.state.info && window.inspector.state.info.name === 'panda' && "
                      "window.inspector.ready")
    model = dynamics.load_urdf(PANDA)
    assert browser.execute_script("return window.inspector.jointNames()") == list(model.joint_names)
    before = rendered(browser, "panda_link7")
    browser.execute_script("return window.inspector.setJoint('panda_joint1', 1.0)")
    wait_for(browser, "window.inspector.ready")
    after = rendered(browser, "panda_link7")
    q = np.array(browser.execute_script("return window.inspector.state.q"))
    assert q[0] == 1.0
    T = dynamics.forward_kinematics(model, q)[model.frame_index("panda_link7")]
    np.testing.assert_allclose(after, T, atol=1e-6)
    assert np.abs(after - before).max() > 0.05  # it moved
    tau = browser.execute_script("return window.inspector.state.tau")
    np.testing.assert_allclose(tau, dynamics.gravity_torques(model, q), rtol=1e-9, atol=1e-9)
    assert errors(browser) == []


def test_talos_tree_lists_every_joint(browser, server):
    with open(TALOS, "rb") as f:
        rid = httpx.post(server.url + "/v1/robots", content=f.read(), timeout=TIMEOUT,
                         headers={"Content-Type": "application/xml"}).json()["id"]
    open_page(browser, f"{server.url}/inspect/{rid}")
    model = dynamics.load_urdf(TALOS)
    assert browser.execute_script("return window.inspector.jointNames()") == list(model.joint_names)
    merged = browser.execute_script("return Array.from(document.querySelectorAll('#tree .tag.merged'))"
                                    ".map(e => e.parentElement.firstChild.textContent)")
    assert merged == model.info["fixed_joints_merged"]
    assert errors(browser) == []


def test_a_simulated_trajectory_plays_to_its_end(browser, server):
    open_page(browser, server.url + "/inspect/planar_2r")
    browser.execute_script("document.querySelector('[data-tab=trajectory]').click();"
                           "document.getElementById('sim-duration').value = '0.5';"
                           "document.getElementById('sim-run').click();")
    wait_for(browser, "window.inspector.state.ended")
    traj = browser.execute_script("const s = window.inspector.state; return {t: s.traj.t, q: s.traj.q, "
                                  "frame: s.frame, report: s.traj.report}")
    assert traj["frame"] == len(traj["t"]) - 1 and traj["t"][-1] == pytest.approx(0.5)
    model = dynamics.load_urdf(os.path.join(os.path.dirname(dynamics.robots.__file__), "planar_2r.urdf"))
    T = dynamics.forward_kinematics(model, np.array(traj["q"][-1]))[model.frame_index("link2")]
    np.testing.assert_allclose(rendered(browser, "link2"), T, atol=1e-6)
    assert browser.execute_script("return document.querySelectorAll('#plots canvas').length") == 3
    title = browser.execute_script("return document.getElementById('report').textContent")
    assert title.startswith(dynamics.plot.report_title(traj["report"]))
    assert errors(browser) == []


def test_an_invalid_urdf_shows_the_api_message(browser, server):
    open_page(browser, server.url + "/inspect/planar_2r")
    browser.execute_script("document.querySelector('[data-tab=upload]').click()")
    drop(browser, "broken.urdf", BAD_URDF)
    wait_for(browser, "document.getElementById('upload-result').className === 'error'")
    shown = browser.execute_script("return document.getElementById('upload-result').textContent")
    answer = httpx.post(server.url + "/v1/robots", content=BAD_URDF, headers={"Content-Type": "application/xml"})
    assert answer.status_code == 422
    assert shown == answer.json()["detail"] and "missing" in shown
    # the browser logs the refused request itself; nothing else
    assert [e for e in errors(browser) if "/v1/robots" not in e or "422" not in e] == []


def test_the_key_stays_in_the_page(browser, server):
    open_page(browser, server.url + "/inspect/planar_2r")
    browser.execute_script("const k = document.getElementById('api-key'); k.value = 'secret-key-123';"
                           "k.dispatchEvent(new Event('change'));")
    wait_for(browser, "window.inspector.state.key === 'secret-key-123' && window.inspector.ready")
    stored = browser.execute_script("return [localStorage.length, sessionStorage.length, document.cookie]")
    assert stored == [0, 0, ""]
    browser.execute_script("window.inspector.state.key = ''")


def test_a_locked_joint_poses_a_reduced_model(browser, server):
    """joint1 locked at 0.3 and joint2 moved: the page asks for the reduced model (the API's locked), whose
    g(q) is the library's on dynamics.lock_joints, and the tree says the joint is locked."""
    open_page(browser, server.url + "/inspect/planar_2r")
    browser.execute_script("document.querySelector('[data-tab=pose]').click()")
    browser.execute_script("return window.inspector.setJoint('joint1', 0.3)")
    browser.execute_script("document.querySelector('[data-lock=joint1]').click()")
    wait_for(browser, "window.inspector.ready && window.inspector.state.tau[0] === null")
    browser.execute_script("return window.inspector.setJoint('joint2', 0.5)")
    wait_for(browser, "window.inspector.ready")
    model = dynamics.load_urdf(os.path.join(os.path.dirname(dynamics.robots.__file__), "planar_2r.urdf"))
    reduced = dynamics.lock_joints(model, {"joint1": 0.3})
    tau = browser.execute_script("return window.inspector.state.tau")
    assert tau[0] is None
    np.testing.assert_allclose(tau[1:], dynamics.gravity_torques(reduced, np.array([0.5])), rtol=1e-9, atol=1e-12)
    T = dynamics.forward_kinematics(model, np.array([0.3, 0.5]))[model.frame_index("link2")]
    np.testing.assert_allclose(rendered(browser, "link2"), T, atol=1e-6)
    tag = browser.execute_script("return document.querySelector('#tree li[data-joint=joint1] .tag.locked')"
                                 ".textContent")
    assert tag == "locked at 0.300"
    assert errors(browser) == []


def test_a_finished_job_s_run_plays(browser, server):
    """Run 1 of a simulate_many job opened by its id: played to its end, the last frame where the library puts it."""
    job = {"robot": "planar_2r", "kind": "simulate_many", "inputs": {"q0": [[0.1, 0.2], [0.5, -0.3]], "v0": [0, 0]},
           "options": {"duration": 0.3, "sample_dt": 0.01}}
    jid = httpx.post(server.url + "/v1/jobs", json=job).json()["id"]
    end = time.monotonic() + TIMEOUT
    while httpx.get(f"{server.url}/v1/jobs/{jid}").json()["status"] != "done":
        assert time.monotonic() < end, "the job did not finish"
        time.sleep(0.5)
    open_page(browser, server.url + "/inspect/planar_2r")
    browser.execute_script("document.querySelector('[data-tab=trajectory]').click();"
                           "document.getElementById('job-id').value = arguments[0];"
                           "document.getElementById('job-run').value = '1';"
                           "document.querySelector('#job-form button').click();", jid)
    wait_for(browser, "window.inspector.state.ended")
    q = httpx.get(f"{server.url}/v1/jobs/{jid}/result").json()["q"][1]
    assert browser.execute_script("return window.inspector.state.traj.q") == q
    model = dynamics.load_urdf(os.path.join(os.path.dirname(dynamics.robots.__file__), "planar_2r.urdf"))
    T = dynamics.forward_kinematics(model, np.array(q[-1]))[model.frame_index("link2")]
    np.testing.assert_allclose(rendered(browser, "link2"), T, atol=1e-6)
    assert errors(browser) == []


def drawn(driver, model) -> np.ndarray:
    """Every body's world matrix as drawn, (nbodies, 4, 4) in the order of bodies."""
    return np.array([rendered(driver, b) for b in model.body_names])


def joint_motion(model, poses: np.ndarray, body: str) -> np.ndarray:
    """The motion of a body's joint as drawn: (parent pose x joint placement)^-1 x body pose, a (4, 4) in the
    joint frame (the root's parent is the world)."""
    i = model.body_names.index(body)
    parent = poses[model.parents[i]] if model.parents[i] >= 0 else np.eye(4)
    return np.linalg.solve(parent @ model.placements[i], poses[i])


def test_every_joint_type_opens_at_the_model_s_neutral_and_each_slider_moves_it(browser, server):
    """A robot with a free, a planar, a spherical, a revolute and a prismatic joint: the page opens at the model's
    own neutral configuration and its first forward kinematics succeeds; every slider of every joint moves the
    bodies it carries to where the library puts them at the page's q."""
    model = dynamics.load_urdf(EVERY_JOINT_URDF, floating_base=True)
    assert {"floating", "planar", "spherical", "revolute", "prismatic"} <= set(model.joint_types)
    rid = httpx.post(server.url + "/v1/robots?floating_base=true", content=EVERY_JOINT_URDF, timeout=TIMEOUT,
                     headers={"Content-Type": "application/xml"}).json()["id"]
    open_page(browser, f"{server.url}/inspect/{rid}")
    state = browser.execute_script("const s = window.inspector.state; return {q: s.q, posed: s.posed, error: s.error}")
    assert state["error"] is None and state["posed"] >= 1  # the first forward kinematics was answered
    np.testing.assert_array_equal(state["q"], model.neutral())
    fk = dynamics.forward_kinematics(model, model.neutral())
    np.testing.assert_allclose(drawn(browser, model), [fk[model.frame_index(b)] for b in model.body_names],
                               atol=1e-6)
    browser.execute_script("document.querySelector('[data-tab=pose]').click()")
    sliders = browser.execute_script(
        "return Array.from(document.querySelectorAll('#sliders input[type=range]'))"
        ".map(i => ({label: i.dataset.joint, lo: Number(i.min), hi: Number(i.max), value: Number(i.value)}))")
    assert len(sliders) == model.nv  # one slider per velocity coordinate: 6 + 3 + 3 + 1 + 1
    k = model.q_index[model.joint_names.index("elbow")]
    assert [s["value"] for s in sliders if s["label"] == "elbow"] == [model.neutral()[k]]  # not 0: outside its limits
    for s in sliders:
        joint = s["label"].split(".")[0]
        i = model.joint_names.index(joint)
        block = slice(model.q_index[i], model.q_index[i] + model.nq_joint[i])
        before = drawn(browser, model)
        q_before = np.array(browser.execute_script("return window.inspector.state.q"))
        browser.execute_script("return window.inspector.setJoint(arguments[0], arguments[1])", s["label"],
                               s["value"] + 0.3 * (s["hi"] - s["value"]))
        wait_for(browser, "window.inspector.ready")
        assert browser.execute_script("return window.inspector.state.error") is None, s["label"]
        q = np.array(browser.execute_script("return window.inspector.state.q"))
        changed = np.flatnonzero(q != q_before)
        assert changed.size and block.start <= changed.min() and changed.max() < block.stop, s["label"]
        after = drawn(browser, model)
        fk = dynamics.forward_kinematics(model, q)
        np.testing.assert_allclose(after, [fk[model.frame_index(b)] for b in model.body_names], atol=1e-6)
        assert np.abs(after[i] - before[i]).max() > 1e-3, s["label"]  # the joint's body moved
    assert errors(browser) == []


def test_the_sliders_of_a_multi_dof_joint_are_its_documented_coordinates(browser, server):
    """The spherical and free joints' angles are the URDF's roll, pitch, yaw (R = Rz(yaw) Ry(pitch) Rx(roll)), the
    planar joint's x, y and theta its motion in its plane: the drawn joint motions are those."""
    model = dynamics.load_urdf(EVERY_JOINT_URDF, floating_base=True)
    rid = httpx.post(server.url + "/v1/robots?floating_base=true", content=EVERY_JOINT_URDF, timeout=TIMEOUT,
                     headers={"Content-Type": "application/xml"}).json()["id"]
    open_page(browser, f"{server.url}/inspect/{rid}")
    root = model.joint_names[0]
    values = {"shoulder.roll": 0.4, "shoulder.pitch": -0.7, "shoulder.yaw": 1.1,
              "slide.x": 0.3, "slide.y": -0.2, "slide.theta": 0.9,
              f"{root}.x": 0.5, f"{root}.y": -0.4, f"{root}.z": 0.3,
              f"{root}.roll": -0.5, f"{root}.pitch": 0.6, f"{root}.yaw": -1.2}
    for label, value in values.items():
        browser.execute_script("return window.inspector.setJoint(arguments[0], arguments[1])", label, value)
    wait_for(browser, "window.inspector.ready")
    assert browser.execute_script("return window.inspector.state.error") is None
    poses = drawn(browser, model)
    M = joint_motion(model, poses, "arm")  # the spherical shoulder turns in place
    np.testing.assert_allclose(M[:3, :3], rpy_to_matrix([0.4, -0.7, 1.1]), atol=1e-9)
    np.testing.assert_allclose(M[:3, 3], 0, atol=1e-9)
    M = joint_motion(model, poses, "cart")  # the planar cart: (x, y) in the plane, theta about its normal z
    np.testing.assert_allclose(M[:3, :3], rpy_to_matrix([0, 0, 0.9]), atol=1e-9)
    np.testing.assert_allclose(M[:3, 3], [0.3, -0.2, 0], atol=1e-9)
    M = joint_motion(model, poses, model.body_names[0])  # the free root: position and roll, pitch, yaw
    np.testing.assert_allclose(M[:3, :3], rpy_to_matrix([-0.5, 0.6, -1.2]), atol=1e-9)
    np.testing.assert_allclose(M[:3, 3], [0.5, -0.4, 0.3], atol=1e-9)
    # the neutral button goes back to the model's neutral, sliders and drawing
    browser.execute_script("document.getElementById('pose-neutral').click()")
    wait_for(browser, "window.inspector.ready")
    np.testing.assert_array_equal(browser.execute_script("return window.inspector.state.q"), model.neutral())
    fk = dynamics.forward_kinematics(model, model.neutral())
    np.testing.assert_allclose(drawn(browser, model), [fk[model.frame_index(b)] for b in model.body_names],
                               atol=1e-6)
    assert errors(browser) == []


def test_the_page_has_sliders_for_every_joint_type_the_library_reads(browser, server):
    open_page(browser, server.url + "/inspect/planar_2r")
    types = {name for kind in KINDS.values() for name in kind.urdf}
    assert set(browser.execute_script("return window.inspector.jointTypes()")) == types


def test_a_locked_spherical_joint_poses_a_reduced_model(browser, server):
    """The shoulder turned by its sliders, then locked: the page names the reduced model with the shoulder's whole
    quaternion (the API's locked), whose g(q) is the library's on dynamics.lock_joints, and the pose still is."""
    model = dynamics.load_urdf(EVERY_JOINT_URDF, floating_base=True)
    rid = httpx.post(server.url + "/v1/robots?floating_base=true", content=EVERY_JOINT_URDF, timeout=TIMEOUT,
                     headers={"Content-Type": "application/xml"}).json()["id"]
    open_page(browser, f"{server.url}/inspect/{rid}")
    browser.execute_script("document.querySelector('[data-tab=pose]').click()")
    for label, value in (("shoulder.pitch", 0.6), ("shoulder.yaw", -0.8)):
        browser.execute_script("return window.inspector.setJoint(arguments[0], arguments[1])", label, value)
    browser.execute_script("document.querySelector('[data-lock=shoulder]').click()")
    i = model.joint_names.index("shoulder")
    k, kv = model.q_index[i], model.v_index[i]
    wait_for(browser, f"window.inspector.ready && window.inspector.state.tau[{kv}] === null")
    browser.execute_script("return window.inspector.setJoint('elbow', 1.5)")
    wait_for(browser, "window.inspector.ready")
    q = np.array(browser.execute_script("return window.inspector.state.q"))
    reduced = dynamics.lock_joints(model, {"shoulder": q[k:k + 4]})
    kept = np.concatenate([np.arange(model.q_index[j], model.q_index[j] + model.nq_joint[j])
                           for j in range(len(model.joint_names)) if j != i])
    tau = browser.execute_script("return window.inspector.state.tau")
    assert tau[kv:kv + 3] == [None] * 3
    np.testing.assert_allclose([t for t in tau if t is not None], dynamics.gravity_torques(reduced, q[kept]),
                               rtol=1e-9, atol=1e-12)
    fk = dynamics.forward_kinematics(model, q)
    np.testing.assert_allclose(drawn(browser, model), [fk[model.frame_index(b)] for b in model.body_names],
                               atol=1e-6)
    assert errors(browser) == []
