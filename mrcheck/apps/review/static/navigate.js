// mrcheck review: "Navigate" -- move through the CAD from a shot's pose. The server renders every
// view (api/view, one WebSocket; the model never reaches the page): "move" frames at half size
// while the view changes, a converged "rest" frame once it stops. The photo stays at the shot's
// pose and fades as the camera leaves it. Uses app.js's S, $, $$, api, status, toImage, panes.
"use strict";
(() => {  // one scope: app.js and addphoto.js share the page's global names
  const NAV = { on: false, ws: null, cam: null, id: 0, shown: 0, sent: {}, pivot: null, restTimer: null,
    lastChange: 0, moveTimes: [], measuring: false, points: [], url: null, fadePx: 40 };

  // -- camera: world-to-camera R (rows: the camera's x, y, z in the world) and t ------------------
  const mul = (A, B) => A.map((r) => B[0].map((_, j) => r[0] * B[0][j] + r[1] * B[1][j] + r[2] * B[2][j]));
  const tr = (A) => A[0].map((_, j) => A.map((r) => r[j]));
  const apply = (A, v) => A.map((r) => r[0] * v[0] + r[1] * v[1] + r[2] * v[2]);
  const add = (a, b, k = 1) => a.map((v, i) => v + k * b[i]);
  const norm = (v) => Math.hypot(...v);
  function axisAngle(axis, angle) {  // Rodrigues
    const n = norm(axis), [x, y, z] = axis.map((v) => v / n), c = Math.cos(angle), s = Math.sin(angle), C = 1 - c;
    return [[c + x * x * C, x * y * C - z * s, x * z * C + y * s], [y * x * C + z * s, c + y * y * C, y * z * C - x * s],
      [z * x * C - y * s, z * y * C + x * s, c + z * z * C]];
  }
  const centre = (cam) => apply(tr(cam.R), cam.t).map((v) => -v);
  const placed = (R, C) => ({ R, t: apply(R, C).map((v) => -v) });
  function shotCam() { const c = S.shot.camera; return { R: c.R.map((r) => r.slice()), t: c.t.slice() }; }
  function project(cam, X) {  // pinhole pixel (served size) of world point X
    const K = S.shot.camera.K, p = add(apply(cam.R, X), cam.t);
    return [K[0][0] * p[0] / p[2] + K[0][2], K[1][1] * p[1] / p[2] + K[1][2]];
  }

  function orbit(dx, dy) {  // about the pivot: turn about the world's up (z), tilt about the camera's x
    const P = NAV.pivot || add(centre(NAV.cam), NAV.cam.R[2], 10);
    const Q = mul(axisAngle(NAV.cam.R[0], -dy * 0.005), axisAngle([0, 0, 1], -dx * 0.005));
    const C = add(P, apply(Q, add(centre(NAV.cam), P, -1)));
    NAV.cam = placed(mul(NAV.cam.R, tr(Q)), C);
  }
  function pan(dx, dy) {  // the point under the cursor follows it: metres per served pixel at the pivot's depth
    const C = centre(NAV.cam), depth = NAV.pivot ? norm(add(NAV.pivot, C, -1)) : 10;
    const k = depth / S.shot.camera.K[0][0] * (S.shot.camera.width / S.shot.width) / S.t.s;
    NAV.cam = placed(NAV.cam.R, add(add(C, NAV.cam.R[0], -dx * k), NAV.cam.R[1], -dy * k));
  }
  function walk(forward, right, up) {  // metres along the view's horizontal heading, sideways, up
    const level = (v) => { const h = [v[0], v[1], 0], n = norm(h) || 1; return h.map((x) => x / n); };
    let C = add(centre(NAV.cam), level(NAV.cam.R[2]), forward);
    C = add(add(C, level(NAV.cam.R[0]), right), [0, 0, 1], up);
    NAV.cam = placed(NAV.cam.R, C);
  }

  // -- the session ------------------------------------------------------------------------------
  function send(quality) {
    if (!NAV.ws || NAV.ws.readyState !== WebSocket.OPEN) return;
    const id = ++NAV.id;
    NAV.sent[id] = performance.now();
    NAV.ws.send(JSON.stringify({ id, shot: S.shot.name, R: NAV.cam.R, t: NAV.cam.t, mode: S.mode,
      intensity: S.info.intensities[S.level], quality }));
  }
  function changed() {  // a new camera: a quick frame now, the converged one once it rests
    NAV.lastChange = performance.now();
    send("move"); fade();
    clearTimeout(NAV.restTimer);
    NAV.restTimer = setTimeout(() => send("rest"), 250);
  }
  function show(h, blob) {
    if (h.id < NAV.shown || !NAV.on) return;
    NAV.shown = h.id;
    const url = URL.createObjectURL(blob), old = NAV.url;
    NAV.url = url;
    for (const r of $$(".render")) r.src = url;
    if (old) setTimeout(() => URL.revokeObjectURL(old), 1000);
    const now = performance.now();
    if (h.quality === "move") {
      NAV.moveTimes = NAV.moveTimes.filter((t) => now - t < 2000).concat([now]);
    } else {
      document.body.dataset.restMs = Math.round(now - NAV.lastChange);
    }
    const fps = NAV.moveTimes.length > 1 ? (NAV.moveTimes.length - 1) * 1000 / (now - NAV.moveTimes[0]) : 0;
    document.body.dataset.view = `${h.id}|${h.quality}`;
    if (h.quality === "move") document.body.dataset.moveFps = fps.toFixed(2);
    status(`navigate: ${h.quality === "move" ? `moving, ${fps.toFixed(1)} frames/s` : `at rest, ${h.accumulate} AO frames`}, ` +
      `${h.width}x${h.height} in ${Math.round(h.ms)} ms` + (NAV.measuring ? "; measuring: click two CAD points" : ""));
  }
  // the photo is where the shot was taken: it fades out as the camera leaves that pose (the shift of a
  // point ahead of the shot, plus its turn, in pixels), and the CAD takes its place
  function fade() {
    const shot = shotCam(), ahead = add(centre(shot), shot.R[2], NAV.pivot ? norm(add(NAV.pivot, centre(shot), -1)) : 10);
    const [u, v] = project(NAV.cam, ahead), [u0, v0] = project(shot, ahead);
    const turn = Math.acos(Math.min(1, Math.max(-1, (mul(NAV.cam.R, tr(shot.R)).reduce((s, r, i) => s + r[i], 0) - 1) / 2)));
    const away = Math.hypot(u - u0, v - v0) + turn * S.shot.camera.K[0][0];
    const photo = Math.max(0, 1 - away / NAV.fadePx), cad = S.opacity / 100;
    for (const p of $$(".photo")) p.style.opacity = photo;
    for (const r of $$(".render")) r.style.opacity = cad + (1 - cad) * (1 - photo);
    for (const m of $$(".markers")) m.style.visibility = away < 1 ? "visible" : "hidden";  // markers sit on the photo
    document.body.dataset.away = away.toFixed(2);
  }
  async function pickAt(ev) {  // the CAD under the cursor in the current view: {point, instance, ...} or null
    const p = toImage(panes[0], ev), k = S.shot.camera.width / S.shot.width;
    if (p.x < 0 || p.y < 0 || p.x >= S.shot.width || p.y >= S.shot.height) return null;
    const hit = await api("POST", "api/view/pick", { shot: S.shot.name, R: NAV.cam.R, t: NAV.cam.t, x: p.x * k, y: p.y * k });
    return hit.point ? hit : null;
  }

  async function navStart() {
    if (!S.shot) return;
    NAV.on = true; NAV.cam = shotCam(); NAV.pivot = null; NAV.points = [];
    S.view = "overlay"; $("#view").value = "overlay"; $("#view").disabled = true; applyView();
    $("#navigate").classList.add("active"); $("#measure").hidden = false;
    try {
      NAV.ws = await openSocket("api/view", "frame", show, "view", (ws) => NAV.ws === ws && NAV.on);
    } catch (e) { navStop(); status("view: no connection to the server's render session"); return; }
    changed();
  }
  function navStop() {
    NAV.on = false; clearTimeout(NAV.restTimer);
    if (NAV.ws) NAV.ws.close();
    NAV.ws = null; NAV.measuring = false;
    $("#navigate").classList.remove("active"); $("#measure").hidden = true; $("#measure").classList.remove("active");
    $("#view").disabled = false;
    for (const p of $$(".photo")) p.style.opacity = 1;
    for (const m of $$(".markers")) m.style.visibility = "visible";
    applyView(); baseLoadRender();
  }
  function backToShot() { NAV.cam = shotCam(); changed(); }
  function toggleMeasure() {
    NAV.measuring = !NAV.measuring; NAV.points = [];
    $("#measure").classList.toggle("active", NAV.measuring);
    status(NAV.measuring ? "measure: click two CAD points" : "measure off");
  }
  async function measureClick(ev) {
    const hit = await pickAt(ev);
    if (!hit) { status("measure: no CAD there"); return; }
    NAV.points = NAV.points.length >= 2 ? [hit] : NAV.points.concat([hit]);
    if (NAV.points.length < 2) { status(`measure: A on ${hit.instance}; click B`); return; }
    const [a, b] = NAV.points, d = norm(add(a.point, b.point, -1));
    document.body.dataset.measure = d.toFixed(4);
    status(`distance ${d.toFixed(3)} m (A on ${a.instance}, B on ${b.instance})`);
  }

  // -- input: in capture on the viewport, before app.js's zoom, pan and markers -----------------
  const viewport = $("#viewport");
  viewport.addEventListener("mousedown", (ev) => {
    if (!NAV.on || !panes[0].contains(ev.target)) return;
    ev.stopPropagation(); ev.preventDefault();
    if (NAV.measuring && ev.button === 0 && !ev.shiftKey) { measureClick(ev); return; }
    const panning = ev.shiftKey || ev.button === 2;
    pickAt(ev).then((hit) => { if (hit) NAV.pivot = hit.point; }).catch(() => {});
    let last = { x: ev.clientX, y: ev.clientY };
    const move = (e) => {
      const dx = e.clientX - last.x, dy = e.clientY - last.y;
      last = { x: e.clientX, y: e.clientY };
      if (panning) pan(dx, dy); else orbit(dx, dy);
      changed();
    };
    const up = () => { window.removeEventListener("mousemove", move); window.removeEventListener("mouseup", up); };
    window.addEventListener("mousemove", move); window.addEventListener("mouseup", up);
  }, true);
  viewport.addEventListener("contextmenu", (ev) => { if (NAV.on) ev.preventDefault(); }, true);
  viewport.addEventListener("wheel", async (ev) => {
    if (!NAV.on) return;
    ev.stopPropagation(); ev.preventDefault();
    const hit = await pickAt(ev).catch(() => null);
    const C = centre(NAV.cam), target = hit ? hit.point : add(C, NAV.cam.R[2], 10);
    NAV.cam = placed(NAV.cam.R, add(C, add(target, C, -1), ev.deltaY < 0 ? 0.2 : -0.25));  // towards the cursor's point
    changed();
  }, { capture: true, passive: false });
  let hoverTimer = null;
  viewport.addEventListener("mousemove", (ev) => {
    if (!NAV.on || ev.buttons) return;
    ev.stopPropagation();
    clearTimeout(hoverTimer);
    hoverTimer = setTimeout(async () => {  // the part under the cursor, in this view
      const hit = await pickAt(ev).catch(() => null), tip = $("#tooltip"), vr = viewport.getBoundingClientRect();
      tip.style.left = ev.clientX - vr.left + 14 + "px"; tip.style.top = ev.clientY - vr.top + 14 + "px";
      const element = hit ? [hit.ifc_class, hit.name, hit.storey].filter(Boolean).join(", ") : "";
      tip.textContent = hit ? `${hit.instance}${element ? ` (${element})` : ""} - ${hit.distance.toFixed(2)} m` : "no CAD";
      tip.style.display = "block";
    }, 80);
  }, true);
  document.addEventListener("keydown", (ev) => {
    if (!NAV.on || /^(INPUT|TEXTAREA|SELECT)$/.test(ev.target.tagName)) return;
    const step = ev.shiftKey ? 1.0 : 0.25, keys = {
      w: () => walk(step, 0, 0), ArrowUp: () => walk(step, 0, 0), s: () => walk(-step, 0, 0), ArrowDown: () => walk(-step, 0, 0),
      a: () => walk(0, -step, 0), ArrowLeft: () => walk(0, -step, 0), d: () => walk(0, step, 0), ArrowRight: () => walk(0, step, 0),
      q: () => walk(0, 0, -step), e: () => walk(0, 0, step) };
    const key = ev.key.length === 1 ? ev.key.toLowerCase() : ev.key;
    if (key === "h") { backToShot(); return; }
    if (key === "m") { toggleMeasure(); return; }
    if (keys[key]) { ev.preventDefault(); keys[key](); changed(); }
  });

  // app.js's render and shot changes, while navigating: the session renders the mode and intensity
  // chosen; another shot ends navigation
  const baseLoadRender = loadRender;
  loadRender = function () { if (NAV.on) send("rest"); else baseLoadRender(); };  // eslint-disable-line no-global-assign
  const baseSelectShot = selectShot;
  selectShot = async function (shot) { if (NAV.on) navStop(); return baseSelectShot(shot); };  // eslint-disable-line no-global-assign
  $("#navigate").onclick = () => (NAV.on ? navStop() : navStart());
  $("#measure").onclick = toggleMeasure;
})();
