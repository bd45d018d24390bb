// kbplanner 4D playback: the world glTF at the world date, the robot, the carried element, workers and
// their paths, animated along the simulated time. Data: window.KBP_PLAYBACK (see analysis/playback.py).
// Site frame (x east, y north, z up) -> three.js (x, z, -y), as the world's glTF export.
(function () {
  "use strict";
  const { THREE, GLTFLoader, OrbitControls } = window.KBP_THREE;
  const D = window.KBP_PLAYBACK;
  const state = document.getElementById("state");
  const errors = [];
  window.addEventListener("error", (e) => { errors.push(String(e.message)); state.dataset.error = errors.join("; "); });

  const v3 = (x, y, z) => new THREE.Vector3(x, z, -y);
  const T = D.t;
  const n = T.length;
  const canvas = document.getElementById("view");
  const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: false });
  renderer.setPixelRatio(1);
  // section cut above the task storey, so the robot inside the building stays visible
  const cut = new THREE.Plane(new THREE.Vector3(0, -1, 0), D.cut_z);
  const cutBox = document.getElementById("cut");
  const applyCut = () => { renderer.clippingPlanes = cutBox.checked && D.cut_z !== null ? [cut] : []; };
  applyCut();
  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0xf4f4f0);
  scene.add(new THREE.HemisphereLight(0xffffff, 0x888888, 2.2));
  const sun = new THREE.DirectionalLight(0xffffff, 1.5);
  sun.position.set(30, 60, 20);
  scene.add(sun);
  const camera = new THREE.PerspectiveCamera(45, 1, 0.1, 2000);
  const controls = new OrbitControls(camera, canvas);
  const [x0, y0, x1, y1] = D.extent;
  const centre = v3((x0 + x1) / 2, (y0 + y1) / 2, 0);
  const span = Math.max(x1 - x0, y1 - y0);
  camera.position.copy(centre).add(new THREE.Vector3(0, span * 0.95, span * 0.55));
  controls.target.copy(centre);
  controls.update();
  const ground = new THREE.Mesh(new THREE.PlaneGeometry(x1 - x0, y1 - y0),
    new THREE.MeshLambertMaterial({ color: 0xdfe6d8 }));
  ground.rotation.x = -Math.PI / 2;
  ground.position.set(centre.x, D.ground_z - 0.01, centre.z);
  scene.add(ground);

  // robot: its footprint as a magenta box with a heading marker (unlit: the tests find its pixels)
  const robot = new THREE.Group();
  for (const r of D.robot.rects) {
    const box = new THREE.Mesh(new THREE.BoxGeometry(r.length, D.robot.height, r.width),
      new THREE.MeshBasicMaterial({ color: 0xff00ff }));
    box.position.set(r.cx, D.robot.height / 2, -r.cy);
    box.rotation.y = r.yaw;
    robot.add(box);
  }
  const nose = new THREE.Mesh(new THREE.ConeGeometry(0.12, 0.35, 12), new THREE.MeshBasicMaterial({ color: 0x550055 }));
  nose.rotation.z = -Math.PI / 2;
  nose.position.set(0.6, D.robot.height + 0.05, 0);
  robot.add(nose);
  scene.add(robot);
  // the carried element: its footprint in the carry mode, lifted
  const carried = new THREE.Mesh(new THREE.BoxGeometry(1, 0.12, 1), new THREE.MeshLambertMaterial({ color: 0x20a0a0 }));
  carried.visible = false;
  robot.add(carried);

  const line = (xs, ys, z, colour) => {
    const pts = [];
    for (let i = 0; i < xs.length; i++) if (xs[i] !== null) pts.push(v3(xs[i], ys[i], z));
    const g = new THREE.BufferGeometry().setFromPoints(pts);
    return new THREE.Line(g, new THREE.LineBasicMaterial({ color: colour }));
  };
  scene.add(line(D.robot.x, D.robot.y, D.ground_z + 0.03, 0x222222));
  const workers = D.workers.map((w) => {
    scene.add(line(w.x, w.y, D.ground_z + 0.02, 0x4a7bd0));
    const body = new THREE.Mesh(new THREE.CylinderGeometry(0.25, 0.25, 1.75, 16),
      new THREE.MeshLambertMaterial({ color: 0x1f4fbf }));
    scene.add(body);
    return { w, body };
  });
  for (const m of D.marks) {
    const ring = new THREE.Mesh(new THREE.RingGeometry(0.35, 0.5, 24),
      new THREE.MeshBasicMaterial({ color: m.kind === "stop" ? 0xd02020 : 0xe0a000, side: THREE.DoubleSide }));
    ring.rotation.x = -Math.PI / 2;
    ring.position.copy(v3(m.x, m.y, D.ground_z + 0.04));
    scene.add(ring);
  }

  const elements = {};  // GlobalId -> three node of the task element (at storage in the glTF)
  const slider = document.getElementById("time");
  const label = document.getElementById("clock");
  slider.max = String(T[n - 1]);
  slider.step = "0.1";
  let now = 0;

  const index = (t) => {  // last sample at or before t
    let lo = 0, hi = n - 1;
    while (lo < hi) { const mid = (lo + hi + 1) >> 1; if (T[mid] <= t) lo = mid; else hi = mid - 1; }
    return lo;
  };
  const mat4 = (m) => new THREE.Matrix4().fromArray(m);

  function setTime(t) {
    now = Math.min(Math.max(t, 0), T[n - 1]);
    const i = index(now);
    const x = D.robot.x[i], y = D.robot.y[i], yaw = D.robot.yaw[i];
    robot.position.copy(v3(x, y, D.ground_z));
    robot.rotation.y = yaw;
    for (const { w, body } of workers) {
      const ok = w.x[i] !== null;
      body.visible = ok;
      if (ok) body.position.copy(v3(w.x[i], w.y[i], D.ground_z + 0.875));
    }
    const held = D.carried[i];
    carried.visible = false;
    for (const [gid, e] of Object.entries(D.elements)) {
      const node = elements[gid];
      if (!node) continue;
      const installed = e.installed_t !== null && now >= e.installed_t;
      node.visible = gid !== held;
      node.matrix.copy(mat4(installed ? e.installed : e.storage));
      node.matrixAutoUpdate = false;
      node.matrixWorldNeedsUpdate = true;
    }
    if (held && D.elements[held]) {
      const fp = (D.elements[held].footprints || {})[D.carry_mode[i]] || (D.elements[held].footprints || {}).normal;
      if (fp) {
        carried.scale.set(fp.length, 1, fp.width);
        carried.position.set(fp.cx, D.robot.height + 0.6, -fp.cy);
        carried.rotation.y = fp.yaw;
        carried.visible = true;
      }
    }
    slider.value = String(now);
    const mm = Math.floor(now / 60), ss = (now - 60 * mm).toFixed(1).padStart(4, "0");
    label.textContent = `${mm}:${ss} / ${(T[n - 1] / 60).toFixed(1)} min`;
    state.dataset.t = now.toFixed(2);
    state.dataset.robot = `${x.toFixed(2)},${y.toFixed(2)},${yaw.toFixed(3)}`;
    state.dataset.carried = held || "";
    state.dataset.installed = Object.values(D.elements).filter((e) => e.installed_t !== null && now >= e.installed_t).length;
    render();
  }

  function render() {
    const w = canvas.clientWidth, h = canvas.clientHeight;
    if (canvas.width !== w || canvas.height !== h) { renderer.setSize(w, h, false); camera.aspect = w / h; camera.updateProjectionMatrix(); }
    renderer.render(scene, camera);
  }

  // timeline marks: stops and near misses
  const marks = document.getElementById("marks");
  for (const m of D.marks) {
    const tick = document.createElement("span");
    tick.className = `mark ${m.kind}`;
    tick.style.left = `${(100 * m.t) / T[n - 1]}%`;
    tick.title = `${m.kind} at ${m.t.toFixed(1)} s: ${m.text}`;
    tick.addEventListener("click", () => setTime(m.t));
    marks.appendChild(tick);
  }

  let playing = false, last = null;
  const play = document.getElementById("play");
  const speed = document.getElementById("speed");
  play.addEventListener("click", () => { playing = !playing; play.textContent = playing ? "pause" : "play"; last = null; if (playing) requestAnimationFrame(tick); });
  function tick(ts) {
    if (!playing) return;
    if (last !== null) setTime(now + ((ts - last) / 1000) * Number(speed.value));
    last = ts;
    if (now >= T[n - 1]) { playing = false; play.textContent = "play"; return; }
    requestAnimationFrame(tick);
  }
  slider.addEventListener("input", () => setTime(Number(slider.value)));
  cutBox.addEventListener("change", () => { applyCut(); render(); });
  controls.addEventListener("change", render);
  window.addEventListener("resize", render);

  const start = () => {
    const m = /t=([0-9.]+)/.exec(location.hash);
    if (m) { slider.value = m[1]; slider.dispatchEvent(new Event("input")); } else setTime(0);
    state.dataset.ready = "1";
  };
  const bytes = Uint8Array.from(atob(document.getElementById("world-glb").textContent.trim()), (c) => c.charCodeAt(0));
  new GLTFLoader().parse(bytes.buffer, "", (gltf) => {
    scene.add(gltf.scene);
    gltf.scene.traverse((o) => { if (o.name && o.name.startsWith("task/")) elements[o.name.slice(5)] = o; });
    start();
  }, (err) => { errors.push(`glTF: ${err}`); state.dataset.error = errors.join("; "); start(); });
})();
