// mrcheck review: "Live" -- the check through this device's camera. The video plays in the page at
// its own rate; every new video frame is sent (its time and a JPEG at the shot's served size) to
// api/live, which tracks the newest one waiting whenever it is done with the last (the others
// are dropped there: no queue, and no round trip between two frames) from the shot's pose, and
// answers the pose and the CAD layer at it; the layer is blended over the video with the CAD
// opacity slider (no round trip). Frames are never stored. The track starts at the shot's pose,
// a named viewpoint's or the markers' (#live-start); "Clicks" freezes a frame and hands it to
// "Add photo" (addphoto.js), and Live starts again from the shot saved there.
// Uses app.js's S, $, $$, status, panes.
"use strict";
(() => {  // one scope: app.js, addphoto.js and navigate.js share the page's global names
  const LIVE = { on: false, ws: null, stream: null, video: null, layer: null, encoding: false, sent: 0, got: 0,
    lost: 0, recovered: 0, wasLost: false, times: [], url: null, canvas: document.createElement("canvas"), still: null };

  function sendFrame() {  // the current video frame, at Live's camera's size (LIVE.cam)
    if (LIVE.on && !LIVE.still) nextFrame();
    if (!LIVE.on || LIVE.still || LIVE.encoding || !LIVE.ws || LIVE.ws.readyState !== WebSocket.OPEN || LIVE.video.readyState < 2) return;
    if (LIVE.ws.bufferedAmount > 2e6) return;  // a slow link: let it drain rather than queue frames in the socket
    const c = LIVE.canvas, cam = LIVE.cam;
    c.width = cam.width; c.height = cam.height;
    c.getContext("2d").drawImage(LIVE.video, 0, 0, c.width, c.height);
    LIVE.encoding = true;
    const taken = performance.now() / 1000;  // the frame's time: the server scales its motion prediction by it
    c.toBlob((blob) => {
      LIVE.encoding = false;
      if (!blob || !LIVE.ws) return;
      LIVE.ws.send(new Blob([new Float64Array([taken]).buffer, blob])); LIVE.sent++;  // little-endian on every browser's platform
    }, "image/jpeg", 0.85);
  }
  function nextFrame() {  // once per new video frame where the browser can say so, else every 33 ms
    if (LIVE.video.requestVideoFrameCallback) LIVE.video.requestVideoFrameCallback(sendFrame);
    else setTimeout(sendFrame, 33);
  }
  function shown(h, blob) {
    if (!LIVE.on) return;
    if (LIVE.still && h.time === LIVE.still.time) { LIVE.still.resolve(h); return; }
    document.body.dataset.liveWaiting = h.waiting ? "1" : "";
    if (h.waiting) {  // no pose yet: no layer (the markers are not in view)
      LIVE.layer.style.visibility = "hidden"; status(`live: ${h.reason}`); return;
    }
    LIVE.layer.style.visibility = "";
    const url = URL.createObjectURL(blob), old = LIVE.url;
    LIVE.url = url; LIVE.layer.src = url;
    if (old) setTimeout(() => URL.revokeObjectURL(old), 1000);
    const now = performance.now();
    LIVE.times = LIVE.times.filter((t) => now - t < 3000).concat([now]);
    if (!h.lost && LIVE.wasLost) LIVE.recovered++;  // tracked again after a lost stretch
    LIVE.got++; if (h.lost) LIVE.lost++; LIVE.wasLost = h.lost;
    const rate = LIVE.times.length > 1 ? (LIVE.times.length - 1) * 1000 / (now - LIVE.times[0]) : 0;
    Object.assign(document.body.dataset, { liveFrames: LIVE.got, liveLost: LIVE.lost, liveRecovered: LIVE.recovered,
      livePose: JSON.stringify({ R: h.R, t: h.t, lost: h.lost }),
      liveRate: rate.toFixed(2) });
    status(`live: ${h.lost ? `LOST (${h.reason})` : `support ${Math.round(100 * h.support)} %, rms ${h.rms_px} px`}, ` +
      `${rate.toFixed(1)} poses/s, ${Math.round(h.ms)} ms a frame`);
  }
  // freeze and mark: the video stops, its frame is tracked once more, and saved with that pose as
  // a new shot of the review, on which the planner places markers as on any other
  async function freeze() {
    if (!LIVE.on || LIVE.still) return;
    LIVE.video.pause();
    const c = LIVE.canvas, cam = LIVE.cam, time = performance.now() / 1000;
    c.width = cam.width; c.height = cam.height;
    c.getContext("2d").drawImage(LIVE.video, 0, 0, c.width, c.height);
    const posed = new Promise((resolve) => { LIVE.still = { time, resolve }; });
    const jpeg = await new Promise((resolve) => c.toBlob(resolve, "image/jpeg", 0.92));
    LIVE.ws.send(new Blob([new Float64Array([time]).buffer, jpeg]));
    status("live: frozen; tracking the frame once more...");
    const pose = await posed, from = S.shot.name;
    const image = c.toDataURL("image/jpeg", 0.92).split(",")[1];
    liveStop();
    if (pose.lost) { status(`live: the frozen frame was not tracked (${pose.reason}): not saved`); return; }
    const shot = await api("POST", "api/live/freeze", { shot: from, R: pose.R, t: pose.t, image });
    S.shots.push(shot); addShotItem(shot); await selectShot(shot);
    document.body.dataset.frozen = shot.name;
    status(`frozen as shot ${shot.name} (from ${from}): click the image to place a marker`);
  }
  // start from clicks: the frame stops, goes to "Add photo" with the live intrinsics; the shot
  // saved there is where Live starts again
  async function clicks() {
    if (!LIVE.on) return;
    LIVE.video.pause();
    const c = LIVE.canvas, cam = LIVE.cam;
    c.width = cam.width; c.height = cam.height;
    c.getContext("2d").drawImage(LIVE.video, 0, 0, c.width, c.height);
    const image = c.toDataURL("image/png").split(",")[1], from = S.shot.name;
    liveStop();
    const staged = await api("POST", "api/live/clicks", { shot: from, image });
    status("live: click 4 or more points on the frame and the same on the CAD, Solve, Save: Live starts from that shot");
    await apOpenWith(staged, (shot) => { $("#live-start").value = "shot"; liveStart(); });
  }
  function blend() { if (LIVE.layer) LIVE.layer.style.opacity = S.opacity / 100; }
  function startMessage() {  // where the track starts (#live-start): the shot's pose, a viewpoint's, the markers'
    const from = $("#live-start").value, start = { type: "start", shot: S.shot.name };
    if (from.startsWith("view:")) start.viewpoint = from.slice(5);
    if (from === "markers") start.markers = true;
    return start;
  }

  async function liveStart() {
    if (!S.shot || !navigator.mediaDevices) { status("live: this page cannot open a camera (HTTPS is needed off this machine)"); return; }
    // Live's own intrinsics (--live-intrinsics or Calibrate), at their size; else the shot's served camera
    const own = await api("GET", "api/live/camera").catch(() => ({}));
    LIVE.cam = own.width ? own : S.shot.camera;
    try {
      LIVE.stream = await navigator.mediaDevices.getUserMedia({ audio: false,
        video: { facingMode: { ideal: "environment" }, width: { ideal: LIVE.cam.width }, height: { ideal: LIVE.cam.height } } });
    } catch (e) { status(`live: no camera (${e.name}: ${e.message})`); return; }
    LIVE.on = true; LIVE.sent = LIVE.got = LIVE.lost = LIVE.recovered = 0; LIVE.wasLost = false; LIVE.times = [];
    LIVE.encoding = false;
    Object.assign(document.body.dataset, { liveFrames: 0, liveLost: 0, liveRecovered: 0, livePose: "" });
    const stage = $(".stage", panes[0]);
    LIVE.video = Object.assign(document.createElement("video"), { muted: true, autoplay: true, playsInline: true });
    LIVE.video.className = "live"; LIVE.video.srcObject = LIVE.stream;
    LIVE.layer = Object.assign(document.createElement("img"), { className: "live-layer", alt: "" });
    stage.append(LIVE.video, LIVE.layer); blend();
    for (const el of $$(".photo, .render, .edges, .markers", stage)) el.style.visibility = "hidden";
    $("#live").classList.add("active"); $("#navigate").disabled = true; $("#view").disabled = true;
    $("#freeze").hidden = false; $("#live-clicks").hidden = false; $("#live-start").disabled = true;
    try {
      LIVE.ws = await openSocket("api/live", "pose", shown, "live", (ws) => LIVE.ws === ws && LIVE.on);
    } catch (e) { liveStop(); status("live: no connection to the server's live session"); return; }
    LIVE.ws.send(JSON.stringify(startMessage()));
    await LIVE.video.play().catch(() => {});
    nextFrame();
  }
  function liveStop() {
    LIVE.on = false; LIVE.still = null; $("#freeze").hidden = true; $("#live-clicks").hidden = true;
    $("#live-start").disabled = false; document.body.dataset.liveWaiting = "";
    if (LIVE.ws) LIVE.ws.close();
    if (LIVE.stream) for (const track of LIVE.stream.getTracks()) track.stop();
    for (const el of [LIVE.video, LIVE.layer]) if (el) el.remove();
    LIVE.ws = LIVE.stream = LIVE.video = LIVE.layer = null;
    for (const el of $$(".photo, .render, .edges, .markers", $(".stage", panes[0]))) el.style.visibility = "";
    $("#live").classList.remove("active"); $("#navigate").disabled = false; $("#view").disabled = false;
    applyView();
  }
  $("#live").onclick = () => (LIVE.on ? liveStop() : liveStart());
  $("#freeze").onclick = freeze;
  $("#live-clicks").onclick = () => clicks().catch(() => {});
  $("#opacity").addEventListener("input", blend);
  const baseSelectShot = selectShot;
  selectShot = async function (shot) { if (LIVE.on) liveStop(); return baseSelectShot(shot); };  // eslint-disable-line no-global-assign
})();
