"""The inspector's screenshots in the docs (docs/inspector-panda.png, -talos.png, -anymal.png, -trajectory.png),
made by the page.

    python -m benchmarks.inspector_screenshots [--url http://127.0.0.1:8000]

Starts a service (or uses the one at --url), uploads Panda, Talos and ANYmal from example-robot-data, opens
``/inspect/{id}`` in headless Chromium (the system's, through Selenium, as tests/test_inspector.py does), poses
each robot with the page's own sliders and saves the window. ANYmal B as published is refused (its dummy
``base`` link has every inertia entry 1e-6, products included: no rigid body has that matrix, and the page shows
the service's message when the file is dropped); it is uploaded with that link's products of inertia set to 0.
"""

from __future__ import annotations

import argparse
import io
import re
import sys
import tempfile
import time
from pathlib import Path

import httpx

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests"))

from robots import erd  # noqa: E402
from service_fixtures import Server  # noqa: E402

ROBOTS = {
    "panda": (erd("panda_description/urdf/panda.urdf"), False, {"panda_joint2": -0.5, "panda_joint4": -2.2,
                                                                 "panda_joint6": 1.8}),
    "talos": (erd("talos_data/robots/talos_reduced.urdf"), False, {"arm_left_4_joint": -1.2,
                                                                   "arm_right_4_joint": -1.2}),
    "anymal": (erd("anymal_b_simple_description/robots/anymal.urdf"), True, {
        "root_joint.z": 0.5, "LF_HFE": 0.5, "RF_HFE": 0.5, "LH_HFE": -0.5, "RH_HFE": -0.5,
        "LF_KFE": -0.9, "RF_KFE": -0.9, "LH_KFE": 0.9, "RH_KFE": 0.9}),
}


def urdf_text(name: str, path: str) -> str:
    text = Path(path).read_text()
    if name == "anymal":  # the dummy base link's placeholder products of inertia (see the module docstring)
        text = re.sub(r'<inertia ixx="1e-6" ixy="1e-6" ixz="1e-6" iyy="1e-6" iyz="1e-6" izz="1e-6"/>',
                      '<inertia ixx="1e-6" ixy="0" ixz="0" iyy="1e-6" iyz="0" izz="1e-6"/>', text, count=1)
    return text


def browser():
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    options = webdriver.ChromeOptions()
    options.binary_location = "/usr/bin/chromium"
    for arg in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--window-size=1100,680",
                "--enable-unsafe-swiftshader", "--use-angle=swiftshader", "--hide-scrollbars"):
        options.add_argument(arg)
    return webdriver.Chrome(options=options, service=Service("/usr/bin/chromedriver"))


def wait(driver, script: str, timeout: float = 600.0) -> None:
    end = time.monotonic() + timeout
    while not driver.execute_script(f"return {script}"):
        if time.monotonic() > end:
            raise RuntimeError(f"timed out: {script}")
        time.sleep(0.1)


def shoot(driver, base: str, name: str, rid: str, pose: dict[str, float], out: Path) -> None:
    from PIL import Image
    driver.get(f"{base}/inspect/{rid}")
    wait(driver, "window.inspector && window.inspector.ready")
    for joint, value in pose.items():
        driver.execute_script("return window.inspector.setJoint(arguments[0], arguments[1])", joint, value)
    wait(driver, "window.inspector.ready")
    driver.execute_script("window.inspector.fitCamera()")
    time.sleep(1.0)
    png = Image.open(io.BytesIO(driver.get_screenshot_as_png())).convert("RGB")
    png.quantize(colors=256, method=Image.Quantize.MEDIANCUT).save(out, optimize=True)
    print(f"{out} ({out.stat().st_size // 1024} KiB)")


def shoot_trajectory(driver, base: str, out: Path) -> None:
    """planar_3r released from a bent pose under gravity, played to its end beside its plots."""
    from PIL import Image
    driver.get(f"{base}/inspect/planar_3r")
    wait(driver, "window.inspector && window.inspector.ready")
    for joint, value in {"joint1": 0.8, "joint2": -0.6, "joint3": 0.9}.items():
        driver.execute_script("return window.inspector.setJoint(arguments[0], arguments[1])", joint, value)
    driver.execute_script("document.querySelector('[data-tab=trajectory]').click();"
                          "document.getElementById('sim-duration').value = '2';"
                          "document.getElementById('sim-run').click();")
    wait(driver, "window.inspector.state.ended")
    driver.execute_script("window.inspector.fitCamera()")
    time.sleep(1.0)
    png = Image.open(io.BytesIO(driver.get_screenshot_as_png())).convert("RGB")
    png.quantize(colors=256, method=Image.Quantize.MEDIANCUT).save(out, optimize=True)
    print(f"{out} ({out.stat().st_size // 1024} KiB)")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--url", help="a running service (default: start one)")
    args = p.parse_args(argv)
    server = None
    if args.url:
        base = args.url.rstrip("/")
    else:
        server = Server(Path(tempfile.mkdtemp()) / "store").start()
        base = server.url
    driver = browser()
    try:
        for name, (path, floating, pose) in ROBOTS.items():
            r = httpx.post(f"{base}/v1/robots", content=urdf_text(name, path).encode(), timeout=600,
                           params={"floating_base": str(floating).lower()}, headers={"Content-Type": "application/xml"})
            r.raise_for_status()
            shoot(driver, base, name, r.json()["id"], pose, REPO / "docs" / f"inspector-{name}.png")
        shoot_trajectory(driver, base, REPO / "docs" / "inspector-trajectory.png")
    finally:
        driver.quit()
        if server:
            server.stop()
    return 0


if __name__ == "__main__":
    sys.exit(main())
