// mrcheck review, "Add photo": pick or upload a photo and its intrinsics, click 4+ points on the
// photo and the same points on a CAD view, solve (the server ray-casts the CAD clicks, solves the
// pose, snaps it onto the photo's edges), look at the overlay and the residuals, save the shot.
// Uses app.js's globals ($, $$, enc, S, addShotItem, selectShot, zoomed, panOrClick).
"use strict";
const AP = { photo: null, intrinsics: null, view: null, size: null, cad: null, clicks: { photo: [], cad: [] },
  panes: {}, result: null, busy: false, afterSave: null };

function apMessage(text, error = false) {
  const m = $("#ap-msg"); m.textContent = text; m.classList.toggle("error", error);
}
async function apCall(method, url, body, raw) {
  const headers = raw ? { "Content-Type": "application/octet-stream" } : body ? { "Content-Type": "application/json" } : {};
  const res = await fetch(url, { method, headers, body: raw || (body ? JSON.stringify(body) : undefined) }).catch(() => null);
  if (!res) { apMessage("no connection to the server", true); throw new Error("offline"); }
  const data = await res.json().catch(() => ({}));
  if (!res.ok) {
    apMessage(`${data.error || res.status}${(data.details || []).length ? ": " + data.details.join("; ") : ""}`, true);
    throw new Error(data.error);
  }
  return data;
}

// -- panes: the stage is the image's native size; wheel zooms, a drag pans, a click is a point --
function apPane(side) { return AP.panes[side]; }
function apFit(side) {
  const p = apPane(side); if (!p.size) return;
  const r = p.el.getBoundingClientRect(), s = Math.min(r.width / p.size[0], r.height / p.size[1]);
  p.t = { s, x: (r.width - p.size[0] * s) / 2, y: (r.height - p.size[1] * s) / 2 }; apTransform(side);
}
function apTransform(side) {
  const p = apPane(side), { s, x, y } = p.t;
  p.stage.style.transform = `translate(${x}px, ${y}px) scale(${s})`;
  for (const c of $$(".ap-click", p.stage)) c.style.transform = `scale(${1 / s})`;
}
function apSetImage(side, url, size) {
  const p = apPane(side); p.size = size;
  p.stage.style.width = size[0] + "px"; p.stage.style.height = size[1] + "px";
  p.img.src = url; apFit(side);
}
function apInit(side, el, img, onClick) {
  const p = AP.panes[side] = { el, img, stage: $(".ap-stage", el), t: { s: 1, x: 0, y: 0 }, size: null };
  el.addEventListener("wheel", (ev) => {
    ev.preventDefault(); p.t = zoomed(p.t, el, ev, 0.02); apTransform(side);
  }, { passive: false });
  el.addEventListener("mousedown", (ev) => {
    if (ev.button !== 0 || !p.size) return;
    panOrClick(ev, () => p.t, () => apTransform(side), (e) => {
      const r = el.getBoundingClientRect();
      const x = (e.clientX - r.left - p.t.x) / p.t.s, y = (e.clientY - r.top - p.t.y) / p.t.s;
      if (x >= 0 && y >= 0 && x < p.size[0] && y < p.size[1]) onClick(x, y);
    });
  });
}

// -- clicks --------------------------------------------------------------------------------
function apDrawClicks() {
  const n = Math.min(AP.clicks.photo.length, AP.clicks.cad.length);
  for (const side of ["photo", "cad"]) {
    const layer = $(".ap-clicks", apPane(side).stage); layer.textContent = "";
    AP.clicks[side].forEach(([x, y], i) => {
      const el = document.createElement("div");
      el.className = "ap-click" + (i >= n ? " open" : ""); el.textContent = i + 1;
      el.style.left = x + "px"; el.style.top = y + "px"; layer.appendChild(el);
    });
    apTransform(side);
  }
  const np = AP.clicks.photo.length, nc = AP.clicks.cad.length;
  document.body.dataset.apPairs = String(n);
  if (!AP.busy) apMessage(np > nc ? `point ${np}: now click it on the CAD (right)`
    : nc > np ? `point ${nc}: now click it on the photo (left)` : `${n} pair(s)` + (n < 4 ? `: at least 4 needed` : ": Solve when done"));
}
function apClicked(side, x, y) {
  if (!AP.photo || !AP.size) { apMessage("choose a photo and its intrinsics first", true); return; }
  apForget();
  AP.clicks[side].push([x, y]); apDrawClicks();
}
async function apCadClick(x, y) {
  if (!AP.view) return;
  const hit = await apCall("GET", `api/addphoto/views/${enc(AP.view)}/pick?x=${x.toFixed(2)}&y=${y.toFixed(2)}`);
  if (!hit.instance) { apMessage(`that CAD click (${x.toFixed(0)}, ${y.toFixed(0)}) hits no part: click on the model`, true); return; }
  apClicked("cad", x, y);
}
function apForget() {  // a new click or input makes the last solve stale
  AP.result = null; $("#ap-save").disabled = true; $("#ap-show-overlay").checked = false;
  $("#ap-show-overlay").disabled = true; $("#ap-overlay-img").hidden = true; $("#ap-residuals").textContent = "";
}

// -- inputs --------------------------------------------------------------------------------
function apOptions(select, names, prefix, first) {
  select.textContent = ""; select.add(new Option(first, ""));
  for (const n of names) select.add(new Option(n, `${prefix}${n}`));
}
async function apOpen() {
  $("#addphoto").hidden = false;
  const files = await apCall("GET", "api/addphoto/files");
  apOptions($("#ap-photo"), files.photos, "folder:", `(a photo in ${files.folder}, or upload)`);
  apOptions($("#ap-intrinsics"), files.cameras, "folder:", "(a camera file, or upload)");
  const views = await apCall("GET", "api/addphoto/views");
  const vs = $("#ap-view"); vs.textContent = "";
  for (const v of views) { const o = new Option(v.label, v.name); o.dataset.size = `${v.width},${v.height}`; vs.add(o); }
  await apSetView(vs.value);
  document.body.dataset.apOpen = "1";
}
async function apOpenWith(staged, afterSave) {  // a frozen live frame and the live intrinsics (live.js: Live from clicks)
  await apOpen();
  $("#ap-photo").add(new Option(`${staged.photo.name} (live frame)`, staged.photo.ref)); $("#ap-photo").value = staged.photo.ref;
  $("#ap-intrinsics").add(new Option(`${staged.intrinsics.name} (live camera)`, staged.intrinsics.ref));
  $("#ap-intrinsics").value = staged.intrinsics.ref;
  AP.afterSave = afterSave;  // once the shot is saved: Live starts from it
  await apInputs();
}
async function apSetView(name) {
  AP.view = name; AP.clicks.cad = []; apForget();
  const o = [...$("#ap-view").options].find((k) => k.value === name);
  apSetImage("cad", `api/addphoto/views/${enc(name)}/render.png`, o.dataset.size.split(",").map(Number));
  apDrawClicks();
}
async function apInputs() {  // both chosen: the photo's size checked against the intrinsics, the photo shown
  AP.photo = $("#ap-photo").value || null; AP.intrinsics = $("#ap-intrinsics").value || null;
  AP.clicks.photo = []; apForget(); AP.size = null;
  if (!AP.photo || !AP.intrinsics) { apDrawClicks(); apMessage(`choose ${AP.photo ? "the intrinsics" : "a photo"} too`); return; }
  const info = await apCall("GET", `api/addphoto/photo?photo=${enc(AP.photo)}&intrinsics=${enc(AP.intrinsics)}`);
  AP.size = [info.width, info.height];
  apSetImage("photo", `api/addphoto/photo.png?photo=${enc(AP.photo)}`, AP.size);
  apDrawClicks();
  if (info.warnings.length) apMessage(info.warnings.join("; "));
}
async function apUpload(input, kind, select) {
  const file = input.files[0]; if (!file) return;
  apMessage(`uploading ${file.name}...`);
  try {
    const up = await apCall("POST", `api/addphoto/upload?kind=${kind}&filename=${enc(file.name)}`, null, file);
    select.add(new Option(`${up.name} (uploaded)`, up.ref)); select.value = up.ref;
    await apInputs();
  } finally { input.value = ""; }
}

// -- solve and save ------------------------------------------------------------------------
async function apSolve() {
  const n = Math.min(AP.clicks.photo.length, AP.clicks.cad.length);
  const pairs = AP.clicks.photo.slice(0, n).map((p, i) => ({ photo: p, cad: AP.clicks.cad[i] }));
  AP.busy = true; apMessage("solving...");
  try {
    const r = await apCall("POST", "api/addphoto/solve", { photo: AP.photo || "", intrinsics: AP.intrinsics || "",
      view: AP.view || "", pairs, snap: $("#ap-snap").checked });
    AP.result = r;
    $("#ap-overlay-img").src = `api/addphoto/results/${r.id}/overlay.png`;
    $("#ap-show-overlay").disabled = false; $("#ap-show-overlay").checked = true; $("#ap-overlay-img").hidden = false;
    $("#ap-save").disabled = false;
    const list = $("#ap-residuals"); list.textContent = "";
    r.residuals_px.forEach((e, i) => {
      const li = document.createElement("li");
      li.textContent = `${e.toFixed(2)} px` + (r.snapped ? ` (clicks alone: ${r.click_residuals_px[i].toFixed(2)} px)` : "")
        + (r.rejected.includes(i) ? ": left out (does not agree with the others: a mis-click?)" : "");
      li.classList.toggle("rejected", r.rejected.includes(i));
      list.appendChild(li);
    });
    const left = r.rejected.length ? ` (${r.rejected.length} pair(s) left out)` : "";
    apMessage(`click RMS ${r.rms_px.toFixed(2)} px${left}; ${r.note}` + (r.warnings.length ? `; ${r.warnings.filter((w) => w !== r.note).join("; ")}` : ""));
    document.body.dataset.apSolved = r.id;
  } finally { AP.busy = false; }
}
async function apSave() {
  if (!AP.result) return;
  const shot = await apCall("POST", `api/addphoto/results/${AP.result.id}/save`);
  S.shots.push(shot); addShotItem(shot);
  apMessage(`saved shot ${shot.name} (photo ${shot.photo}) in ${shot.folder}`);
  document.body.dataset.apSaved = shot.name;
  apForget(); AP.clicks = { photo: [], cad: [] }; apDrawClicks();
  $("#addphoto").hidden = true; await selectShot(shot);
  const after = AP.afterSave; AP.afterSave = null;
  if (after) after(shot);
}

apInit("photo", $("#ap-left"), $("#ap-photo-img"), (x, y) => apClicked("photo", x, y));
apInit("cad", $("#ap-right"), $("#ap-cad-img"), (x, y) => apCadClick(x, y).catch(() => {}));
AP.panes.photo.overlay = $("#ap-overlay-img");
$("#add-photo").onclick = () => apOpen().catch(() => {});
$("#ap-close").onclick = () => { $("#addphoto").hidden = true; AP.afterSave = null; };
$("#ap-photo").onchange = () => apInputs().catch(() => {});
$("#ap-intrinsics").onchange = () => apInputs().catch(() => {});
$("#ap-view").onchange = (ev) => apSetView(ev.target.value).catch(() => {});
$("#ap-photo-file").onchange = (ev) => apUpload(ev.target, "photo", $("#ap-photo")).catch(() => {});
$("#ap-intrinsics-file").onchange = (ev) => apUpload(ev.target, "intrinsics", $("#ap-intrinsics")).catch(() => {});
$("#ap-undo").onclick = () => {
  const side = AP.clicks.photo.length > AP.clicks.cad.length ? "photo" : "cad";
  AP.clicks[side].pop(); apForget(); apDrawClicks();
};
$("#ap-clear").onclick = () => { AP.clicks = { photo: [], cad: [] }; apForget(); apDrawClicks(); };
$("#ap-solve").onclick = () => apSolve().catch(() => {});
$("#ap-save").onclick = () => apSave().catch(() => {});
$("#ap-show-overlay").onchange = (ev) => { $("#ap-overlay-img").hidden = !ev.target.checked; };
window.addEventListener("resize", () => { if (!$("#addphoto").hidden) { apFit("photo"); apFit("cad"); } });
