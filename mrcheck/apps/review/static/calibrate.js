// mrcheck review, "Calibrate this camera": the device's camera (the rear one, at the size asked)
// films a chessboard; a frame every half second (one in flight, as JPEG at the video's own size)
// goes to api/calibrate/frame, where the board is found and its corners kept for a view that
// differs from those kept (frames are never stored); the corners found are drawn over the video.
// "Solve" calibrates from the views (as mrcheck calibrate: outlier views rejected), saves the
// camera beside the review database and makes it Live's. Uses app.js's $ and status.
"use strict";
(() => {  // one scope: the page's scripts share the global names
  const CB = { on: false, stream: null, busy: false, timer: null, canvas: document.createElement("canvas"), state: null };
  const EVERY_MS = 500;

  function message(text, error = false) { const m = $("#cb-msg"); m.textContent = text; m.classList.toggle("error", error); }
  async function call(method, url, body, raw) {
    const get = method === "GET";  // a GET has no body
    const headers = get ? {} : { "Content-Type": raw ? "application/octet-stream" : "application/json" };
    const res = await fetch(url, { method, headers, body: get ? undefined : raw || JSON.stringify(body || {}) }).catch(() => null);
    if (!res) { message("no connection to the server", true); throw new Error("offline"); }
    const data = await res.json().catch(() => ({}));
    if (!res.ok) { message(data.error || `error ${res.status}`, true); throw new Error(data.error); }
    return data;
  }
  function counted(s) {
    CB.state = s;
    $("#cb-count").textContent = `views kept: ${s.views} / ${s.needed} needed (at most ${s.max})`;
    $("#cb-solve").disabled = s.views < s.needed;
    document.body.dataset.calibViews = s.views;
  }
  function drawCorners(r) {  // the corners found, over the video: green when the view was kept
    const c = $("#cb-corners"), v = $("#cb-video");
    c.width = v.videoWidth; c.height = v.videoHeight;
    const g = c.getContext("2d");
    g.clearRect(0, 0, c.width, c.height);
    g.strokeStyle = r.kept ? "#0f0" : "#ff0"; g.lineWidth = Math.max(2, c.width / 320);
    for (const [x, y] of r.corners) { g.beginPath(); g.arc(x, y, 2 * g.lineWidth, 0, 2 * Math.PI); g.stroke(); }
  }
  async function sendFrame() {
    const v = $("#cb-video");
    if (!CB.on || CB.busy || v.readyState < 2 || !v.videoWidth) return;
    const c = CB.canvas;
    c.width = v.videoWidth; c.height = v.videoHeight;  // the camera's own pixels: the intrinsics are of them
    c.getContext("2d").drawImage(v, 0, 0);
    CB.busy = true;
    try {
      const blob = await new Promise((resolve) => c.toBlob(resolve, "image/jpeg", 0.85));  // a 1920x1080 frame must stay within --max-body (1 MiB by default)
      if (!blob || !CB.on) return;
      const r = await call("POST", "api/calibrate/frame", null, blob);
      if (!CB.on) return;
      counted(r); drawCorners(r);
      message(r.kept ? `view ${r.views} kept (${r.frame_width}x${r.frame_height})` : r.reason, false);
    } catch (e) { /* said in the message line */ } finally { CB.busy = false; }
  }
  async function startCalibration() {
    const board = $("#cb-board").value.trim();
    if (!board) { message("type the board: chessboard:COLSxROWS:SQUARE (inner corners, metres), e.g. chessboard:9x6:0.025", true); return; }
    stopCamera();
    counted(await call("POST", "api/calibrate/start", { board }));
    if (!navigator.mediaDevices) { message("this page cannot open a camera (HTTPS is needed off this machine)", true); return; }
    const [w, h] = $("#cb-size").value.split("x").map(Number);
    try {
      CB.stream = await navigator.mediaDevices.getUserMedia({ audio: false,
        video: { facingMode: { ideal: "environment" }, width: { ideal: w }, height: { ideal: h } } });
    } catch (e) { message(`no camera (${e.name}: ${e.message})`, true); return; }
    const v = $("#cb-video");
    v.srcObject = CB.stream; await v.play().catch(() => {});
    CB.on = true; CB.timer = setInterval(sendFrame, EVERY_MS);
    message(`show the board ${board} at many places and tilts (up to 40 degrees), filling the corners of the image too`);
  }
  function stopCamera() {
    CB.on = false; clearInterval(CB.timer); CB.timer = null;
    if (CB.stream) for (const track of CB.stream.getTracks()) track.stop();
    CB.stream = null; $("#cb-video").srcObject = null;
  }
  async function solve() {
    $("#cb-solve").disabled = true;
    stopCamera();
    message("solving...");
    let r;
    try { r = await call("POST", "api/calibrate/solve", {}); } catch (e) { if (CB.state) counted(CB.state); return; }
    const f = (k) => `${k} ${r[k].toFixed(1)} +/- ${r.std[k].toFixed(2)} px`;
    $("#cb-result").textContent = `RMS ${r.rms_px.toFixed(3)} px over ${r.views} views` +
      (r.rejected.length ? ` (${r.rejected.length} rejected: ${r.rejected.join(", ")})` : "") +
      `\n${["fx", "fy", "cx", "cy"].map(f).join(", ")}\ndist ${r.dist.map((d) => d.toFixed(4)).join(", ")}` +
      `\nsaved as ${r.path}; Live now tracks at ${r.width}x${r.height} with it` + (r.warning ? `\n${r.warning}` : "");
    message(r.warning ? "calibrated, but poorly determined: see below" : "calibrated: Live uses this camera now", !!r.warning);
    document.body.dataset.calibrated = JSON.stringify(r);
    status(`camera calibrated: fx ${r.fx.toFixed(1)}, RMS ${r.rms_px.toFixed(2)} px`);
  }
  async function open() {
    $("#calibrate-panel").hidden = false; $("#cb-result").textContent = "";
    const s = await call("GET", "api/calibrate").catch(() => null);
    if (!s) return;
    if (!$("#cb-board").value) $("#cb-board").value = s.board || "";
    counted(s);  // the server's calibration: views kept before (by this page or another) until the next Start
    message(s.board ? "print the board, then Start and show it to the camera" : "type the board you printed, then Start");
  }
  function close() { stopCamera(); $("#calibrate-panel").hidden = true; }
  $("#calibrate").onclick = open;
  $("#cb-start").onclick = startCalibration;
  $("#cb-solve").onclick = solve;
  $("#cb-close").onclick = close;
})();
