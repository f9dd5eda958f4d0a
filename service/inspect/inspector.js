// The inspector page: a robot as the service understood it (GET /v1/robots/{id}/inspect), posed through the
// service's forward kinematics, with its gravity torques, and trajectories from simulate or a finished job.
// Every number comes from the API; this script only draws. The API key lives in `state.key` (this page's memory)
// and nowhere else: no localStorage, no cookie. window.inspector is the hook the browser tests read.
"use strict";
(() => {
  const $ = (id) => document.getElementById(id);
  const state = {key: "", robot: null, info: null, q: [], tau: null, traj: null, frame: 0, playing: false,
                 ended: false, error: null, busy: 0, locked: new Set()};
  const scene = {viewer: null, THREE: null, root: null, bodies: {}, layers: {}};

  // -- the API ------------------------------------------------------------------------------------------------
  async function api(method, path, body, type) {
    const headers = {Accept: "application/json"};
    if (state.key) headers.Authorization = `Bearer ${state.key}`;
    if (body !== undefined) headers["Content-Type"] = type || "application/json";
    state.busy++;
    try {
      const r = await fetch(path, {method, headers, cache: "no-store",
                                   body: body === undefined ? undefined : (type ? body : JSON.stringify(body))});
      const text = await r.text();
      let doc = null;
      try { doc = text ? JSON.parse(text) : null; } catch (e) { doc = null; }
      if (!r.ok) {
        const err = new Error(doc && doc.detail ? doc.detail : `${r.status} ${r.statusText}`);
        err.status = r.status;
        throw err;
      }
      return doc;
    } finally {
      state.busy--;
    }
  }

  function say(text, error) {
    $("status").textContent = text;
    $("status").className = error ? "error" : "";
    if (error) state.error = text;
  }

  const fmt = (x, p = 4) => (x === null || x === undefined ? "-" : Number(x).toPrecision(p));
  const el = (tag, text, cls) => {
    const e = document.createElement(tag);
    if (text !== undefined) e.textContent = text;
    if (cls) e.className = cls;
    return e;
  };

  // -- the 3D scene (meshcat's viewer: three.js, z up, orbit controls) ----------------------------------------
  function initViewer() {
    if (typeof MeshCat === "undefined") {
      say("the 3D viewer is not installed on this server: pip install 'dynamics[inspect]'", true);
      return false;
    }
    scene.THREE = MeshCat.THREE;
    scene.viewer = new MeshCat.Viewer($("viewer"));
    scene.viewer.set_property(["Background"], "visible", false);  // (the page's light grey behind the grid)
    scene.viewer.set_property(["Grid"], "visible", false);  // ours instead: the plane z = 0 of the robot's world
    const grid = new MeshCat.THREE.GridHelper(10, 20, 0x607d8b, 0xb0bec5).rotateX(Math.PI / 2);
    scene.viewer.set_object(["floor"], new MeshCat.THREE.Group().add(grid));
    const resize = () => scene.viewer.set_3d_pane_size($("viewer").offsetWidth, $("viewer").offsetHeight);
    window.addEventListener("resize", resize);
    requestAnimationFrame(resize);
    return true;
  }

  function material(color, opacity = 1) {
    const T = scene.THREE;
    return new T.MeshLambertMaterial({color, transparent: opacity < 1, opacity});
  }

  function layer(name, object) {
    (scene.layers[name] = scene.layers[name] || []).push(object);
    object.visible = $("layers").querySelector(`[data-layer=${name}]`).checked;
    return object;
  }

  function fromRows(rows) {  // a (4, 4) row-major nested list -> Matrix4
    const m = new scene.THREE.Matrix4();
    m.set(...rows.flat());
    return m;
  }

  function primitive(g) {  // a collision geometry record -> a mesh in its body frame
    const T = scene.THREE, [a, b, c] = g.size.map((x) => x || 0);
    let geo;
    if (g.kind === "sphere") geo = new T.SphereGeometry(a, 20, 14);
    else if (g.kind === "box") geo = new T.BoxGeometry(a, b, c);
    else if (g.kind === "cylinder") geo = new T.CylinderGeometry(a, a, b, 20).rotateX(Math.PI / 2);
    else if (g.kind === "capsule") {
      geo = new T.CylinderGeometry(a, a, b, 20).rotateX(Math.PI / 2);
      const group = new T.Group();
      group.add(new T.Mesh(geo, material(0x4fc3f7, 0.8)));
      for (const s of [-1, 1]) {
        const cap = new T.Mesh(new T.SphereGeometry(a, 20, 10), material(0x4fc3f7, 0.8));
        cap.position.set(0, 0, s * b / 2);
        group.add(cap);
      }
      group.applyMatrix4(fromRows(g.pose));
      return group;
    } else geo = new T.SphereGeometry(0.01, 8, 6);  // a point
    const mesh = new T.Mesh(geo, material(g.kind === "point" ? 0xd81b60 : 0x4fc3f7, 0.8));
    mesh.applyMatrix4(fromRows(g.pose));
    return mesh;
  }

  function inertiaBox(b) {  // the uniform box of the body's mass and inertia, at its CoM along its principal axes
    const T = scene.THREE, edges = b.box.map((x) => Math.max(x, 0.005));
    const color = b.verdict === "ok" ? 0xb0bec5 : (b.verdict === "warning" ? 0xffb300 : 0xe53935);
    const mesh = new T.Mesh(new T.BoxGeometry(...edges), material(color, 0.85));
    const R = b.principal_axes;
    const m = new T.Matrix4();
    m.set(R[0][0], R[0][1], R[0][2], b.com[0], R[1][0], R[1][1], R[1][2], b.com[1],
          R[2][0], R[2][1], R[2][2], b.com[2], 0, 0, 0, 1);
    mesh.applyMatrix4(m);
    return mesh;
  }

  function bodyGroup(b, geometry, frames) {
    const T = scene.THREE, group = new T.Group();
    group.matrixAutoUpdate = false;
    group.name = b.name;
    const own = geometry.filter((g) => g.body === b.name);
    if (own.length) for (const g of own) group.add(layer("contact", primitive(g)));
    else if (b.mass > 0) group.add(layer("shapes", inertiaBox(b)));
    if (b.mass > 0) {
      const com = new T.Mesh(new T.SphereGeometry(0.012, 12, 8), material(0xd32f2f));
      com.position.set(...b.com);
      group.add(layer("com", com));
    }
    const axis = new T.Vector3(...b.axis);
    if (axis.length() > 0) {
      group.add(layer("axes", new T.ArrowHelper(axis.normalize(), new T.Vector3(), 0.15, 0xfdd835, 0.04, 0.025)));
    }
    for (const f of frames) {
      const ax = new T.AxesHelper(0.05);
      ax.applyMatrix4(fromRows(f.placement));
      group.add(layer("frames", ax));
    }
    return group;
  }

  function bones(info) {  // a line from each body's joint to its children's, in the parent body's frame
    const T = scene.THREE;
    info.bodies_inspected.forEach((b) => {
      if (b.parent < 0) return;
      const p = b.placement, pts = [new T.Vector3(), new T.Vector3(p[0][3], p[1][3], p[2][3])];
      const line = new T.Line(new T.BufferGeometry().setFromPoints(pts), new T.LineBasicMaterial({color: 0x37474f}));
      scene.bodies[info.bodies_inspected[b.parent].name].add(layer("shapes", line));
    });
  }

  function buildScene(info) {
    const T = scene.THREE;
    scene.bodies = {};
    scene.layers = {};
    scene.root = new T.Group();
    const geometry = info.collision_geometry || [];
    const framesOf = {};
    for (const f of info.frames) (framesOf[f.body === null ? "" : f.body] ||= []).push(f);
    info.bodies_inspected.forEach((b, i) => {
      const g = bodyGroup(b, geometry, framesOf[b.name] || []);
      scene.bodies[b.name] = g;
      scene.root.add(g);
    });
    bones(info);
    for (const g of geometry.filter((g) => g.body === null)) scene.root.add(layer("contact", primitive(g)));
    scene.world = new T.Group();  // the world objects of the last simulation with contact
    scene.root.add(scene.world);
    for (const f of framesOf[""] || []) {
      const ax = new T.AxesHelper(0.05);
      ax.applyMatrix4(fromRows(f.placement));
      scene.root.add(layer("frames", ax));
    }
    scene.viewer.set_object(["robot"], scene.root);
  }

  function halfSpace(normal, offset) {  // the plane normal . x = offset, drawn as a 4 m square, normal up
    const T = scene.THREE, n = new T.Vector3(...normal).normalize();
    const mesh = new T.Mesh(new T.PlaneGeometry(4, 4), new T.MeshLambertMaterial({
      color: 0x8d6e63, transparent: true, opacity: 0.45, side: T.DoubleSide}));
    mesh.quaternion.setFromUnitVectors(new T.Vector3(0, 0, 1), n);
    mesh.position.copy(n.multiplyScalar(offset));
    return mesh;
  }

  function worldObject(o) {  // a simulate request's contact.objects item (service schema) -> a mesh
    if (o.type === "half_space") return halfSpace(o.normal, o.offset || 0);
    const pose = o.pose || [[1, 0, 0, (o.offset || [0, 0, 0])[0]], [0, 1, 0, (o.offset || [0, 0, 0])[1]],
                            [0, 0, 1, (o.offset || [0, 0, 0])[2]], [0, 0, 0, 1]];
    const size = o.type === "sphere" ? [o.radius, 0, 0] : (o.type === "box" ? o.size : [o.radius, o.length, 0]);
    return primitive({kind: o.type, size, pose});
  }

  function drawWorld(contact) {  // the ground and world objects of a simulation's contact (none: nothing)
    scene.world.clear();
    if (contact) {
      const ground = contact.ground === undefined ? true : contact.ground;
      if (ground) scene.world.add(halfSpace(ground.normal || [0, 0, 1], ground.height || 0));
      for (const o of contact.objects || []) scene.world.add(worldObject(o));
    }
    for (const o of scene.world.children) layer("contact", o);
    scene.viewer.set_dirty();
  }

  function pose(placements) {  // world placements (nbodies, 4, 4) of the bodies, in the order of bodies
    state.info.bodies_inspected.forEach((b, i) => {
      const g = scene.bodies[b.name];
      g.matrix.copy(fromRows(placements[i]));
      g.matrixWorldNeedsUpdate = true;
    });
    scene.viewer.set_dirty();
  }

  function fitCamera() {  // look at the robot from the front-left and above, far enough to see all of it
    scene.viewer.scene.updateMatrixWorld(true);  // (the bodies' world matrices, as the next render will have them)
    const T = scene.THREE, box = new T.Box3().setFromObject(scene.root);  // (in three.js' y-up world)
    if (box.isEmpty()) return;
    const c = box.getCenter(new T.Vector3()), d = Math.max(box.getSize(new T.Vector3()).length(), 0.3);
    // meshcat's camera hangs under a node that undoes the scene's turn to z up: it lives in the y-up world,
    // where the robot's (x, y, z) is (x, z, -y); the view from (1, -1, 0.8) in the robot's world
    const v = scene.viewer;
    v.camera.position.set(c.x + 0.7 * d, c.y + 0.55 * d, c.z + 0.7 * d);
    v.controls.target.copy(c);
    v.controls.update();
    v.set_dirty();
  }

  // -- the model tab ----------------------------------------------------------------------------------------
  function jointTag(li, text, cls) { li.appendChild(el("span", text, "tag " + cls)); }

  function renderTree(info) {
    const tree = $("tree"), nodes = {}, s = info.summary;
    tree.innerHTML = "";
    info.joints.forEach((j, i) => {
      const b = info.bodies_inspected[i], li = el("li");
      li.dataset.joint = j.name;
      li.appendChild(el("span", `${j.name}`, "joint-name"));
      const lim = j.lower.length === 1 ? ` [${fmt(j.lower[0], 3)}, ${fmt(j.upper[0], 3)}]` : "";
      li.appendChild(el("span", ` ${j.type}, axis (${b.axis.map((x) => fmt(x, 2)).join(", ")})${lim} → ${j.body}`));
      if (state.locked.has(j.name)) jointTag(li, `locked at ${block(state.q, j).map((x) => fmt(x, 3)).join(", ")}`,
                                             "locked");
      li.appendChild(el("ul"));
      nodes[j.body] = li;
      (j.parent === null ? tree : nodes[j.parent].lastChild).appendChild(li);
    });
    for (const name of s.fixed_joints_merged || []) {
      const li = el("li", name);
      jointTag(li, "fixed, merged", "merged");
      tree.appendChild(li);
    }
    for (const name of s.links_pruned || []) {
      const li = el("li", name);
      jointTag(li, "link pruned", "pruned");
      tree.appendChild(li);
    }
    for (const [name, value] of Object.entries(s.locked_joints || {})) {
      const li = el("li", `${name} = ${JSON.stringify(value)}`);
      jointTag(li, "locked", "locked");
      tree.appendChild(li);
    }
  }

  function renderModel(info) {
    const s = info.summary;
    $("model-summary").textContent = `${info.name} (${info.id}): nq ${info.nq}, nv ${info.nv}, ${s.bodies} bodies, ` +
      `${fmt(info.total_mass)} kg, ${info.floating_base ? "floating" : "fixed"} base; URDF ${s.urdf_links} links, ` +
      `${s.urdf_joints} joints; ${(s.fixed_joints_merged || []).length} fixed joints merged, ` +
      `${(s.links_pruned || []).length} links pruned`;
    const warnings = $("model-warnings");
    warnings.innerHTML = "";
    for (const w of info.warnings) warnings.appendChild(el("li", w));
    renderTree(info);
    const body = $("bodies").tBodies[0];
    body.innerHTML = "";
    for (const b of info.bodies_inspected) {
      const tr = el("tr");
      tr.appendChild(el("td", b.name));
      tr.appendChild(el("td", fmt(b.mass), "num"));
      tr.appendChild(el("td", b.com.map((x) => fmt(x, 3)).join(" "), "num"));
      tr.appendChild(el("td", b.principal_moments.map((x) => fmt(x, 3)).join(" "), "num"));
      const td = el("td");
      const what = b.verdict === "ok" ? "ok" : `${b.positive_definite ? "" : "not positive definite; "}` +
        `${b.triangle ? "" : "triangle inequality violated; "}${fmt(b.relative_violation, 2)}`;
      td.appendChild(el("span", b.mass > 0 ? what : "massless", "tag " + b.verdict));
      tr.appendChild(td);
      body.appendChild(tr);
    }
    const frames = $("frames");
    frames.innerHTML = "";
    for (const f of info.frames) frames.appendChild(el("li", `${f.name} (${f.body === null ? "world" : f.body})`));
  }

  // -- the pose tab: sliders through the service's forward kinematics ----------------------------------------
  // The robot opens at the model's own neutral configuration (the description's `neutral`, dynamics.Model.neutral):
  // the page never rebuilds it. A joint's sliders are a chart of its coordinates in q, one slider per velocity
  // coordinate, picked by the joint's type (the layouts of q are the library's, dynamics.joints.KINDS):
  //   revolute, continuous, prismatic: q itself, within the joint's limits;
  //   spherical: roll, pitch, yaw, the URDF's convention R = Rz(yaw) Ry(pitch) Rx(roll) -> q = [qx, qy, qz, qw];
  //   planar: x, y in its plane and the angle theta about its normal -> q = [x, y, cos theta, sin theta];
  //   floating: x, y, z, then roll, pitch, yaw -> q = [x, y, z, qx, qy, qz, qw].
  // toQ maps a joint's slider values to its block of q, fromQ its block of q to slider values (to place the
  // sliders at the neutral configuration). The service checks every q it is sent, so a wrong chart shows at once.
  const ANGLE = [-Math.PI, Math.PI], TILT = [-Math.PI / 2, Math.PI / 2];  // (pitch within +-pi/2: fromQ is unique)
  const REACH = [-1, 1], BASE_REACH = [-2, 2];  // m: an unlimited translation's slider range
  const RPY = [["roll", ANGLE], ["pitch", TILT], ["yaw", ANGLE]];

  function rpyToQuat(r, p, y) {  // the quaternion (x, y, z, w) of Rz(y) Ry(p) Rx(r): qz(y) qy(p) qx(r)
    const cr = Math.cos(r / 2), sr = Math.sin(r / 2), cp = Math.cos(p / 2), sp = Math.sin(p / 2);
    const cy = Math.cos(y / 2), sy = Math.sin(y / 2);
    return [sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy,
            cr * cp * cy + sr * sp * sy];
  }

  function quatToRpy(x, y, z, w) {  // its inverse, pitch in [-pi/2, pi/2] (any norm: the library normalises too)
    const n = Math.hypot(x, y, z, w);
    [x, y, z, w] = [x / n, y / n, z / n, w / n];
    return [Math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y)),
            Math.asin(Math.max(-1, Math.min(1, 2 * (w * y - z * x)))),
            Math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))];
  }

  const one = (wide) => ({  // a 1-dof joint: its slider is its q, within its limits (else within `wide`)
    coords: (j) => [[null, [j.lower[0] ?? wide[0], j.upper[0] ?? wide[1]]]], toQ: (a) => a, fromQ: (q) => q});
  const CHARTS = {
    revolute: one(ANGLE), continuous: one(ANGLE), prismatic: one(REACH),
    spherical: {coords: () => RPY, toQ: (a) => rpyToQuat(...a), fromQ: (q) => quatToRpy(...q)},
    planar: {coords: () => [["x", REACH], ["y", REACH], ["theta", ANGLE]],
             toQ: ([x, y, t]) => [x, y, Math.cos(t), Math.sin(t)], fromQ: ([x, y, c, s]) => [x, y, Math.atan2(s, c)]},
    floating: {coords: () => [["x", BASE_REACH], ["y", BASE_REACH], ["z", BASE_REACH], ...RPY],
               toQ: (a) => [...a.slice(0, 3), ...rpyToQuat(...a.slice(3))],
               fromQ: (q) => [...q.slice(0, 3), ...quatToRpy(...q.slice(3))]},
  };

  const block = (q, j) => q.slice(j.q_index, j.q_index + j.nq);  // a joint's coordinates in q

  function renderSliders(info) {
    const body = $("sliders").tBodies[0];
    body.innerHTML = "";
    for (const j of info.joints) {
      const chart = CHARTS[j.type];
      if (!chart) {  // a joint type this page has no chart for: held at the model's neutral
        const tr = el("tr"), note = el("td", `held at neutral (no sliders for a ${j.type} joint)`, "hint");
        note.colSpan = 4;
        tr.appendChild(el("td", j.name));
        tr.appendChild(note);
        body.appendChild(tr);
        continue;
      }
      const values = chart.fromQ(block(state.q, j)), inputs = [];
      chart.coords(j).forEach(([coord, [lo, hi]], n) => {
        const tr = el("tr"), input = el("input");
        input.type = "range"; input.min = lo; input.max = hi; input.step = "any"; input.value = values[n];
        input.dataset.joint = coord === null ? j.name : `${j.name}.${coord}`;
        inputs.push(input);
        // the joint's whole block of q from all its sliders: one angle of three never round-trips through q
        input.addEventListener("input", () => {
          state.q.splice(j.q_index, j.nq, ...chart.toQ(inputs.map((x) => Number(x.value))));
          update();
        });
        tr.appendChild(el("td", input.dataset.joint));
        const td = el("td"); td.appendChild(input); tr.appendChild(td);
        tr.appendChild(el("td", fmt(values[n], 3), "num value"));
        tr.appendChild(el("td", "", "num tau"));
        const td2 = el("td");
        if (n === 0) {
          const lock = el("input");
          lock.type = "checkbox"; lock.title = "lock: hold this joint still (the API's locked)";
          lock.dataset.lock = j.name;
          lock.checked = state.locked.has(j.name);
          lock.addEventListener("change", () => { setLocked(j.name, lock.checked); });
          td2.appendChild(lock);
        }
        tr.appendChild(td2);
        tr.dataset.v = j.v_index + n;  // g(q) of the slider's velocity coordinate (a multi-dof joint's: body frame)
        body.appendChild(tr);
      });
    }
  }

  function showPose() {  // the sliders' values (in their charts) and g(q) beside them
    for (const tr of $("sliders").tBodies[0].rows) {
      if (tr.dataset.v === undefined) continue;
      const input = tr.querySelector("input[type=range]");
      tr.querySelector(".value").textContent = fmt(Number(input.value), 3);
      const tau = state.tau[Number(tr.dataset.v)];
      tr.querySelector(".tau").textContent = tau === null ? "locked" : fmt(tau, 4);
    }
  }

  function toNeutral() {
    state.q = state.info.neutral.slice();
    renderSliders(state.info);
  }

  // Locked joints: held at their slider's value, the requests then name a reduced model (the API's `locked`):
  // its q, v and tau leave the locked joints' coordinates out, in the order of the joints kept.
  const free = () => state.info.joints.filter((j) => !state.locked.has(j.name));
  const reduce = (x, index, n) => free().flatMap((j) => x.slice(j[index], j[index] + j[n]));
  function withLocked(body) {  // (the API takes any joint's block of q as a list, a 1-dof joint's too)
    if (!state.locked.size) return body;
    const locked = {};
    for (const j of state.info.joints) if (state.locked.has(j.name)) locked[j.name] = block(state.q, j);
    return {...body, locked};
  }
  function expandTau(tau) {  // the reduced model's tau -> one entry per coordinate of the full model (null: locked)
    const out = new Array(state.info.nv).fill(null);
    let k = 0;
    for (const j of free()) for (let n = 0; n < j.nv; n++) out[j.v_index + n] = tau[k++];
    return out;
  }

  function setLocked(name, on) {
    if (on) state.locked.add(name); else state.locked.delete(name);
    renderTree(state.info);
    update();
  }

  let pending = null, inflight = false;
  async function update() {  // pose the robot at state.q (the latest q wins: requests are never queued up)
    pending = state.q.slice();
    if (inflight) return;
    inflight = true;
    try {
      while (pending) {
        const q = pending;
        pending = null;
        await poseAt(q);
      }
    } catch (e) {
      say(e.message, true);
    } finally {
      inflight = false;
    }
  }

  async function poseAt(q) {
    const id = encodeURIComponent(state.robot), names = state.info.bodies_inspected.map((b) => b.name);
    const qr = reduce(q, "q_index", "nq");
    const [fk, g] = await Promise.all([api("POST", `/v1/robots/${id}/kinematics`, withLocked({q: qr, frames: names})),
                                       api("POST", `/v1/robots/${id}/gravity-torques`, withLocked({q: qr}))]);
    g.tau = expandTau(g.tau);
    state.tau = g.tau;
    pose(fk.placements);
    showPose();
    state.posed = (state.posed || 0) + 1;
  }

  // -- the trajectory tab ------------------------------------------------------------------------------------
  async function simulate(ev) {
    ev.preventDefault();
    const info = state.info, q0 = reduce(state.q, "q_index", "nq");
    const v0 = new Array(free().reduce((n, j) => n + j.nv, 0)).fill(0);
    const duration = Number($("sim-duration").value), kind = $("sim-torque").value;
    const body = withLocked({q0, v0, duration, integrator: $("sim-integrator").value, sample_dt: duration / 200});
    if ($("sim-ground").checked) body.contact = {ground: true};
    if (kind === "pd") body.torque = {type: "pd", q_target: q0, kp: Number($("sim-kp").value), kd: Number($("sim-kd").value)};
    if (kind === "gravity") {
      const g = await api("POST", `/v1/robots/${encodeURIComponent(state.robot)}/gravity-torques`, withLocked({q: q0}));
      body.torque = {type: "constant", tau: g.tau};
    }
    say("simulating ...");
    try {
      const traj = await api("POST", `/v1/robots/${encodeURIComponent(state.robot)}/simulate`, body);
      drawWorld(body.contact);
      traj.locked = body.locked;
      traj.names = free().map((j) => j.name);
      await loadTrajectory(traj);
      say(`simulated ${duration} s: ${traj.t.length} samples`);
    } catch (e) {
      say(e.message, true);
    }
  }

  async function openJob(ev) {
    ev.preventDefault();
    const id = $("job-id").value.trim(), run = Number($("job-run").value) || 0;
    try {
      const job = await api("GET", `/v1/jobs/${encodeURIComponent(id)}`);
      if (job.kind !== "simulate_many") throw new Error(`job: ${id} is a ${job.kind} job; only simulate_many results play`);
      const r = await api("GET", `/v1/jobs/${encodeURIComponent(id)}/result`);
      if (run >= r.q.length) throw new Error(`run: the job has ${r.q.length} runs`);
      const n = r.counts ? r.counts[run] : r.q[run].length, t = Array.isArray(r.t[0]) ? r.t[run] : r.t;
      if (job.robot !== state.robot) await selectRobot(job.robot);
      await loadTrajectory({t: t.slice(0, n), q: r.q[run].slice(0, n), v: r.v[run].slice(0, n),
                            tau: r.tau[run].slice(0, n), report: (r.reports || [])[run] || {}});
      say(`job ${id}, run ${run}: ${n} samples`);
    } catch (e) {
      say(e.message, true);
    }
  }

  const MAX_FRAMES = 1000;  // longer runs are played (and plotted) every k-th sample, the last one kept

  function decimate(traj) {
    const n = traj.t.length, k = Math.ceil(n / MAX_FRAMES);
    if (k <= 1) return traj;
    const keep = (x) => x && x.filter((_, i) => i % k === 0 || i === n - 1);
    return {...traj, t: keep(traj.t), q: keep(traj.q), v: keep(traj.v), tau: keep(traj.tau)};
  }

  async function loadTrajectory(traj) {
    traj = decimate(traj);
    const names = state.info.bodies_inspected.map((b) => b.name);
    const fk = await api("POST", `/v1/robots/${encodeURIComponent(state.robot)}/kinematics`,
                         traj.locked ? {q: traj.q, frames: names, locked: traj.locked} : {q: traj.q, frames: names});
    traj.placements = fk.placements;
    state.traj = traj;
    state.frame = 0;
    state.ended = false;
    $("scrub").max = traj.t.length - 1;
    $("scrub").value = 0;
    const r = traj.report || {};
    $("report").textContent = [Plots.reportTitle(r), ...(r.warnings || []).map((w) => `warning: ${w}`),
      ...["error_estimate", "energy_drift", "energy_balance"].filter((k) => k in r)
        .map((k) => `${k}: ${typeof r[k] === "object" ? JSON.stringify(r[k]) : r[k]}`)].join("\n");
    showFrame(0);
    play(true);
  }

  function showFrame(i) {
    const traj = state.traj;
    state.frame = i;
    pose(traj.placements[i]);
    $("scrub").value = i;
    $("time").textContent = `t = ${traj.t[i].toFixed(3)} s`;
    Plots.draw($("plots"), traj, traj.names || state.info.joint_names, traj.t[i]);
  }

  function play(on) {
    const traj = state.traj;
    if (!traj) return;
    state.playing = on;
    $("play").textContent = on ? "pause" : "play";
    if (!on) return;
    if (state.frame >= traj.t.length - 1) state.frame = 0;
    state.ended = false;
    const start = performance.now() - 1e3 * (traj.t[state.frame] - traj.t[0]);
    const step = (now) => {
      if (!state.playing || state.traj !== traj) return;
      const t = traj.t[0] + (now - start) / 1e3;
      let i = state.frame;
      while (i < traj.t.length - 1 && traj.t[i + 1] <= t) i++;
      if (i !== state.frame) showFrame(i);
      if (i >= traj.t.length - 1) { state.playing = false; state.ended = true; $("play").textContent = "play"; return; }
      requestAnimationFrame(step);
    };
    requestAnimationFrame(step);
  }

  // -- upload -------------------------------------------------------------------------------------------------
  async function upload(file) {
    const out = $("upload-result");
    out.className = "";
    out.textContent = `uploading ${file.name} ...`;
    const params = new URLSearchParams();
    if ($("upload-name").value.trim()) params.set("name", $("upload-name").value.trim());
    if ($("upload-floating").checked) params.set("floating_base", "true");
    try {
      const doc = await api("POST", `/v1/robots?${params}`, await file.text(), "application/xml");
      out.textContent = `stored as ${doc.id} (${doc.name}): nq ${doc.nq}, nv ${doc.nv}` +
        (doc.warnings.length ? `; warnings: ${doc.warnings.join("; ")}` : "");
      await listRobots();
      await selectRobot(doc.id);
    } catch (e) {
      out.className = "error";
      out.textContent = e.message;
    }
  }

  function initUpload() {
    const drop = $("drop");
    drop.addEventListener("dragover", (e) => { e.preventDefault(); drop.classList.add("over"); });
    drop.addEventListener("dragleave", () => drop.classList.remove("over"));
    drop.addEventListener("drop", (e) => {
      e.preventDefault();
      drop.classList.remove("over");
      if (e.dataTransfer.files.length) upload(e.dataTransfer.files[0]);
    });
    $("upload-file").addEventListener("change", (e) => { if (e.target.files.length) upload(e.target.files[0]); });
  }

  // -- robots -------------------------------------------------------------------------------------------------
  async function listRobots() {
    const doc = await api("GET", "/v1/robots"), select = $("robot-select");
    select.innerHTML = "";
    for (const r of doc.robots) {
      const o = el("option", r.bundled ? r.name : `${r.name} (${r.id})`);
      o.value = r.id;
      select.appendChild(o);
    }
    if (state.robot) select.value = state.robot;
  }

  async function selectRobot(ref) {
    say(`loading ${ref} ...`);
    const info = await api("GET", `/v1/robots/${encodeURIComponent(ref)}/inspect`);
    state.robot = info.id;
    state.info = info;
    state.traj = null;
    state.playing = false;
    state.locked = new Set();
    state.q = info.neutral.slice();
    $("robot-select").value = info.id;
    if (!$("robot-select").value) {
      const o = el("option", info.name);
      o.value = info.id;
      $("robot-select").appendChild(o);
      $("robot-select").value = info.id;
    }
    history.replaceState(null, "", `/inspect/${encodeURIComponent(info.bundled ? info.name : info.id)}` + location.search);
    renderModel(info);
    renderSliders(info);
    buildScene(info);
    await poseAt(state.q);
    fitCamera();
    say(`${info.name}: ${info.joints.length} joints, ${info.bodies_inspected.length} bodies`);
  }

  function initTabs() {
    for (const b of $("tabs").querySelectorAll("button")) {
      b.addEventListener("click", () => {
        for (const x of document.querySelectorAll("#tabs button, .tab")) x.classList.remove("active");
        b.classList.add("active");
        $(`tab-${b.dataset.tab}`).classList.add("active");
        if (b.dataset.tab === "trajectory" && state.traj) showFrame(state.frame);
      });
    }
    for (const box of $("layers").querySelectorAll("input")) {
      box.addEventListener("change", () => {
        for (const o of scene.layers[box.dataset.layer] || []) o.visible = box.checked;
        if (scene.viewer) scene.viewer.set_dirty();
      });
    }
  }

  async function start() {
    initTabs();
    initUpload();
    // (Enter in the key's field submits its form: kept on the page. Here, not in an inline onsubmit: the page's
    // Content-Security-Policy runs no inline script.)
    $("key-form").addEventListener("submit", (e) => e.preventDefault());
    $("api-key").addEventListener("change", async (e) => {
      state.key = e.target.value;
      try { await listRobots(); if (!state.info) await selectRobot(initialRobot()); } catch (err) { say(err.message, true); }
    });
    $("robot-select").addEventListener("change", (e) => selectRobot(e.target.value).catch((err) => say(err.message, true)));
    $("pose-neutral").addEventListener("click", () => { toNeutral(); update(); });
    $("sim-form").addEventListener("submit", simulate);
    $("job-form").addEventListener("submit", openJob);
    $("play").addEventListener("click", () => play(!state.playing));
    $("scrub").addEventListener("input", (e) => { play(false); showFrame(Number(e.target.value)); });
    if (!initViewer()) return;
    try {
      await listRobots();
      await selectRobot(initialRobot());
      if (new URLSearchParams(location.search).has("trajectory")) {
        await loadTrajectory(await api("GET", "/inspect/trajectory"));
        $("tabs").querySelector("[data-tab=trajectory]").click();
      }
    } catch (e) {
      say(e.status === 401 ? `${e.message} (type the API key above)` : e.message, true);
    }
    state.ready = true;
  }

  function initialRobot() {
    const parts = location.pathname.split("/").filter(Boolean);
    return parts.length > 1 ? decodeURIComponent(parts[1]) : $("robot-select").value;
  }

  // -- the hook the tests (and a curious user's console) read --------------------------------------------------
  window.inspector = {
    state,
    scene,
    get ready() { return !!state.ready && state.busy === 0; },
    jointNames: () => Array.from(document.querySelectorAll("#tree li[data-joint]")).map((li) => li.dataset.joint),
    jointTypes: () => Object.keys(CHARTS),  // the joint types the pose tab has sliders for
    linkPose(name) {  // a body's world matrix as rendered, in the robot's z-up world (column-major, three.js order)
      const g = scene.bodies[name];
      if (!g) return null;
      scene.viewer.scene.updateMatrixWorld(true);  // (meshcat's root turns three.js' y-up world into z-up)
      return scene.root.matrixWorld.clone().invert().multiply(g.matrixWorld).toArray();
    },
    async setJoint(name, value) {
      const input = document.querySelector(`#sliders input[data-joint="${name}"]`);
      input.value = value;
      input.dispatchEvent(new Event("input"));
      while (inflight || pending) await new Promise((r) => setTimeout(r, 20));
    },
    selectRobot,
    fitCamera,
    upload: (name, text) => upload(new File([text], name, {type: "application/xml"})),
  };

  start();
})();
