// mrcheck review: plain JS, no build step. Blending, swipe, zoom and pan happen on the client.
"use strict";
const $ = (s, root = document) => root.querySelector(s);
const $$ = (s, root = document) => [...root.querySelectorAll(s)];
const S = { info: null, shots: [], shot: null, mode: "phong", level: 1, view: "overlay", edges: false,
  opacity: 50, t: { s: 1, x: 0, y: 0 }, markers: [], selected: null, offsetFor: null };
const panes = [$("#pane-a"), $("#pane-b")];
const enc = encodeURIComponent;

async function api(method, url, body) {
  const res = await fetch(url, { method, headers: body ? { "Content-Type": "application/json" } : {},
    body: body ? JSON.stringify(body) : undefined });
  const data = await res.json().catch(() => ({}));
  if (!res.ok) { status(`error: ${data.error || res.status} ${(data.details || []).join("; ")}`); throw new Error(data.error); }
  return data;
}
function status(text) { $("#status").textContent = text; }
// one of the review's WebSockets (api/view, api/live), ws or wss as the page is, with the page's
// token: a JSON header of type `kind` and the binary message after it go to onPair(header, blob),
// an error to the status line as `what: ...`, as does the socket's closing while live() holds.
// Resolves with the socket once open.
function openSocket(path, kind, onPair, what, live) {
  const token = new URLSearchParams(location.search).get("token");
  const base = location.pathname.replace(/[^/]*$/, "");
  const ws = new WebSocket(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}${base}${path}` +
    (token ? `?token=${encodeURIComponent(token)}` : ""));
  let header = null;
  ws.binaryType = "blob";
  ws.onmessage = (ev) => {
    if (typeof ev.data !== "string") { if (header) onPair(header, ev.data); header = null; return; }
    const m = JSON.parse(ev.data);
    if (m.type === kind) header = m; else status(`${what}: ${m.error}`);
  };
  ws.onclose = (ev) => { if (live(ws)) status(`${what}: connection closed ${ev.reason || ""}`); };
  return new Promise((resolve, reject) => { ws.onopen = () => resolve(ws); ws.onerror = reject; });
}
function imageUrl(kind, mode, level) {
  const q = kind === "render" ? `?mode=${enc(mode)}&intensity=${S.info.intensities[level]}` : "";
  return `api/shots/${enc(S.shot.name)}/${kind}.png${q}`;
}

// -- layout and view ---------------------------------------------------------------------
function applyTransform() {
  const { s, x, y } = S.t;
  for (const st of $$(".stage")) st.style.transform = `translate(${x}px, ${y}px) scale(${s})`;
  for (const m of $$(".marker")) m.style.transform = `scale(${1 / s})`;
}
function fit() {
  if (!S.shot) return;
  const p = visiblePanes()[0].getBoundingClientRect();
  const s = Math.min(p.width / S.shot.width, p.height / S.shot.height);
  S.t = { s, x: (p.width - S.shot.width * s) / 2, y: (p.height - S.shot.height * s) / 2 };
  S.fitted = true;
  applyTransform();
}
function visiblePanes() { return S.view === "side" ? panes : [panes[0]]; }
function applyView() {
  const a = panes[0], b = panes[1];
  b.hidden = S.view !== "side";
  const op = S.opacity / 100;
  const ra = $(".render", a), pb = $(".photo", b), rb = $(".render", b);
  $(".photo", a).style.visibility = "visible";
  if (S.view === "overlay") { ra.style.opacity = op; ra.style.clipPath = "none"; }
  else if (S.view === "swipe") { ra.style.opacity = 1; ra.style.clipPath = `inset(0 0 0 ${S.opacity}%)`; }
  else { ra.style.opacity = 0; pb.style.visibility = "hidden"; rb.style.opacity = 1; }
  $("#opacity").previousSibling.textContent = S.view === "swipe" ? "split " : "CAD opacity ";
  $("#opacity-label").hidden = S.view === "side";  // side by side shows photo and CAD apart: nothing to blend
  for (const e of $$(".edges")) e.style.display = S.edges ? "block" : "none";
}
function loadRender() {
  const mode = S.mode, level = S.level, url = imageUrl("render", mode, level), t0 = performance.now();
  status(`rendering ${mode}...`);
  const img = new Image();
  img.onload = () => {
    if (S.mode !== mode || S.level !== level) return;
    for (const r of $$(".render")) r.src = url;
    status(`${S.info.labels[mode]}, AO ${S.info.intensities[level]}: ${Math.round(performance.now() - t0)} ms`);
    document.body.dataset.loaded = `${S.shot.name}|${mode}|${level}`;
  };
  img.onerror = () => { if (S.mode === mode && S.level === level) imageFailed(url, `render (${mode})`); };
  img.src = url;
}
// an image the server refused: its reason ({"error": ...}, e.g. a photo replaced since start-up)
// in the status line, not only a broken image
async function imageFailed(url, what) {
  failed(what, await fetch(url).catch(() => null));
}
async function failed(what, res) {
  const data = res ? await res.json().catch(() => ({})) : {};
  status(`${what} failed: ${data.error || (res ? res.status : "no connection to the server")}`);
}

// exports are fetched here, then saved: a plain download link that fails ends silently in the
// browser's download list, and the planner never learns why
async function exportFile(link) {
  const what = link.textContent;
  status(`${what}...`);
  const res = await fetch(link.getAttribute("href")).catch(() => null);
  if (!res || !res.ok) return failed(what, res);
  // the server names the file (review.html, review.csv), as it did when the link downloaded it
  const named = /filename="([^"]+)"/.exec(res.headers.get("Content-Disposition") || "");
  const url = URL.createObjectURL(await res.blob());
  const save = Object.assign(document.createElement("a"), { href: url, download: named ? named[1] : "" });
  document.body.appendChild(save); save.click(); save.remove();
  setTimeout(() => URL.revokeObjectURL(url), 60000);
  status(`${what}: saved`);
}

// a BCF file back from a BIM tool: statuses, comments and priorities onto the markers, new topics
// as markers; the result or the refusal in full beside the link (the status line would cut it)
function bcfResult(text, error) {
  const box = $("#bcf-result"); box.textContent = text; box.classList.toggle("error", !!error);
  status(text);
}
async function importBcf(ev) {
  const file = ev.target.files[0]; ev.target.value = "";
  if (!file) return;
  bcfResult("Import BCF...");
  const res = await fetch("api/bcf/import", { method: "POST", body: await file.arrayBuffer(),
    headers: { "Content-Type": "application/octet-stream" } }).catch(() => null);
  if (!res || !res.ok) {
    const data = res ? await res.json().catch(() => ({})) : {};
    return bcfResult(`Import BCF failed: ${data.error || (res ? res.status : "no connection to the server")}`, true);
  }
  const got = await res.json();
  S.markers = await api("GET", `api/markers?shot=${enc(S.shot.name)}`); drawMarkers();
  bcfResult(`Import BCF: ${got.matched} marker(s) updated, ${got.added} added from new topics, ` +
    `${got.unknown} topic(s) no shot sees`);
}

// -- shots ---------------------------------------------------------------------------------
async function selectShot(shot) {
  if (!(await saveEdits())) return;
  S.shot = shot; S.selected = null; $("#editor").hidden = true;
  for (const li of $$("#shot-list li")) li.classList.toggle("active", li.dataset.name === shot.name);
  for (const st of $$(".stage")) { st.style.width = shot.width + "px"; st.style.height = shot.height + "px"; }
  for (const p of $$(".photo")) { p.src = imageUrl("photo"); p.onerror = () => imageFailed(p.src, "photo"); }
  for (const e of $$(".edges")) e.src = imageUrl("edges");
  for (const r of $$(".render")) r.removeAttribute("src");
  fit(); loadRender(); await loadMarkers();
}
async function loadMarkers() {
  S.markers = await api("GET", `api/markers?shot=${enc(S.shot.name)}`);
  drawMarkers();
}

// -- markers -------------------------------------------------------------------------------
function drawMarkers() {
  for (const layer of $$(".markers")) {
    layer.textContent = "";
    for (const m of S.markers) {
      const el = document.createElement("div");
      el.className = `marker sev${m.severity}` + (m.category === "suggested" ? " suggested" : "") + (S.selected === m.id ? " selected" : "");
      el.style.left = m.x + "px"; el.style.top = m.y + "px"; el.textContent = m.id;
      el.dataset.id = m.id; el.title = `${m.category}: ${m.note}`;
      el.addEventListener("mousedown", (ev) => dragMarker(ev, m));
      layer.appendChild(el);
    }
  }
  const list = $("#marker-list"); list.textContent = "";
  for (const m of S.markers) {
    const li = document.createElement("li");
    li.dataset.id = m.id; li.classList.toggle("selected", S.selected === m.id);
    // a BCF import's status (when another tool changed it) and comments show on the marker
    const bcf = (m.status && m.status !== "Open" ? ` [${m.status}]` : "") + (m.comments && m.comments.length ? ` (${m.comments.length} comment${m.comments.length > 1 ? "s" : ""})` : "");
    li.textContent = `#${m.id} ${m.category} (sev ${m.severity}) ${m.part_label || m.part || "-"}: ${m.note}${bcf}`;
    li.title = [m.note, ...(m.comments || []).map((c) => `${c.author}: ${c.text}`)].join("\n");
    li.onclick = () => select(m.id);
    list.appendChild(li);
  }
  applyTransform();
}
// Edits of the selected marker are saved when the planner leaves a field or the marker (another
// marker, a click on the image, another shot, Close), so typed text is never dropped silently.
function editorChanges() {
  const m = S.markers.find((k) => k.id === S.selected);
  if (!m || $("#editor").hidden) return null;
  const now = { category: $("#ed-category").value, severity: Number($("#ed-severity").value), note: $("#ed-note").value,
    status: $("#ed-status").value };
  const diff = Object.fromEntries(Object.entries(now).filter(([k, v]) => m[k] !== v));
  return Object.keys(diff).length ? diff : null;
}
function replaceMarker(m) { S.markers = S.markers.map((k) => (k.id === m.id ? m : k)); }
let saving = Promise.resolve(true);
function saveEdits() {  // one save at a time: a field's blur and the click that caused it do not both PATCH
  const run = async () => {
    const diff = editorChanges();
    if (!diff) return true;
    try {
      const m = await api("PATCH", `api/markers/${S.selected}`, diff);
      replaceMarker(m); drawMarkers(); status(`marker #${m.id} saved`);
      return true;
    } catch (e) { return false; }  // api() shows the error; the editor stays open with the text
  };
  saving = saving.then(run, run);
  return saving;
}
async function select(id) {
  if (!(await saveEdits())) return;  // also for the same marker: the editor is refilled from what was saved
  S.selected = id; const m = S.markers.find((k) => k.id === id);
  $("#editor").hidden = !m;
  if (m) {
    $("#ed-id").textContent = "#" + m.id;
    // the element's name (class, storey) where the scene knows it; its id (a GlobalId) on hover
    $("#ed-part").textContent = m.part ? `on ${m.part_label || m.part}` + (m.distance != null ? ` (${m.distance.toFixed(2)} m)` : "") : "(no CAD part)";
    $("#ed-part").title = m.part || "";
    $("#ed-category").value = m.category; $("#ed-severity").value = m.severity; $("#ed-note").value = m.note;
    fillStatus(m.status || "Open"); fillComments(m); fillOffset(m);
  }
  S.offsetFor = null; $("#ed-measure").classList.remove("active");
  drawMarkers();
}
// the marker's offset from the CAD point that should be there (api/markers/ID/offset): "Offset
// to CAD", then a click on the image at that CAD point
function fillOffset(m) {
  const o = m.offset;
  $("#ed-offset-out").textContent = o ? `${o.distance_m.toFixed(3)} m (x ${o.offset_m.map((c) => (c >= 0 ? "+" : "") + c.toFixed(3)).join(", ")})` : "";
  $("#ed-offset-clear").hidden = !o;
  document.body.dataset.offset = o ? o.distance_m : "";
}
async function measureOffset(x, y) {
  const id = S.offsetFor; S.offsetFor = null; $("#ed-measure").classList.remove("active");
  const m = await api("PUT", `api/markers/${id}/offset`, { x, y });
  replaceMarker(m); fillOffset(m); drawMarkers();
  status(`marker #${id}: ${m.offset.distance_m.toFixed(3)} m from the planned position (across the line of sight)`);
}
$("#ed-measure").onclick = () => {
  if (S.selected === null) return;
  S.offsetFor = S.offsetFor === null ? S.selected : null; $("#ed-measure").classList.toggle("active", S.offsetFor !== null);
  if (S.offsetFor !== null) status(`marker #${S.selected}: click the point of the CAD that should be where the marker is`);
};
$("#ed-offset-clear").onclick = async () => {
  const m = await api("DELETE", `api/markers/${S.selected}/offset`); replaceMarker(m); fillOffset(m); drawMarkers();
};
// a status another tool wrote (BCF's TopicStatus is free text) is offered beside the usual four
function fillStatus(value) {
  const select = $("#ed-status");
  for (const o of [...select.options]) if (o.dataset.extra) o.remove();
  if (![...select.options].some((o) => o.value === value)) {
    const o = new Option(value, value); o.dataset.extra = "1"; select.add(o);
  }
  select.value = value;
}
function fillComments(m) {
  const list = $("#ed-comment-list"); list.textContent = "";
  for (const c of m.comments || []) {
    const li = document.createElement("li"), who = document.createElement("small");
    who.textContent = `${c.author}${c.date ? ", " + c.date.slice(0, 16).replace("T", " ") : ""}: `;
    li.append(who, c.text); list.appendChild(li);
  }
}
async function addComment() {
  const text = $("#ed-comment").value.trim(), id = S.selected;
  if (!text || id === null) return;
  try {
    const m = await api("POST", `api/markers/${id}/comments`, { text });
    replaceMarker(m); $("#ed-comment").value = ""; fillComments(m); drawMarkers(); status(`marker #${id}: comment added`);
  } catch (e) { /* api() shows the error; the text stays in the box */ }
}
async function addMarker(x, y) {
  const m = await api("POST", "api/markers", { shot: S.shot.name, x, y, category: "missing", severity: 2, note: "", mode: S.mode });
  S.markers.push(m); await select(m.id); $("#ed-note").focus();
}
function dragMarker(ev, m) {
  ev.stopPropagation(); ev.preventDefault();
  const start = { x: ev.clientX, y: ev.clientY }, orig = { x: m.x, y: m.y };
  let moved = false;
  const move = (e) => {
    const dx = (e.clientX - start.x) / S.t.s, dy = (e.clientY - start.y) / S.t.s;
    if (Math.abs(dx) + Math.abs(dy) > 2) moved = true;
    m.x = Math.min(S.shot.width - 0.5, Math.max(0, orig.x + dx)); m.y = Math.min(S.shot.height - 0.5, Math.max(0, orig.y + dy));
    for (const el of $$(`.marker[data-id="${m.id}"]`)) { el.style.left = m.x + "px"; el.style.top = m.y + "px"; }
  };
  const up = async () => {
    window.removeEventListener("mousemove", move); window.removeEventListener("mouseup", up);
    await saveEdits();  // the selected marker's typed note first: the move's answer would refill the editor
    if (moved) replaceMarker(await api("PATCH", `api/markers/${m.id}`, { x: m.x, y: m.y }));
    select(m.id);
  };
  window.addEventListener("mousemove", move); window.addEventListener("mouseup", up);
}
$("#editor").addEventListener("submit", async (ev) => {
  ev.preventDefault();
  if (await saveEdits()) status(`marker #${S.selected} saved`);
});
for (const field of ["#ed-category", "#ed-severity", "#ed-note", "#ed-status"]) $(field).addEventListener("change", saveEdits);
$("#ed-comment-add").onclick = addComment;
$("#ed-delete").onclick = async () => {
  const id = S.selected;
  if (!confirm(`Delete marker #${id}? This cannot be undone.`)) return;
  await api("DELETE", `api/markers/${id}`);
  S.markers = S.markers.filter((k) => k.id !== id); select(null);
};
$("#ed-close").onclick = () => select(null);
window.addEventListener("beforeunload", (ev) => { if (editorChanges()) { ev.preventDefault(); ev.returnValue = ""; } });

// -- zoom, pan, click, hover (both panes share one transform) ------------------------------
function toImage(pane, ev) {
  const r = pane.getBoundingClientRect();
  return { x: (ev.clientX - r.left - S.t.x) / S.t.s, y: (ev.clientY - r.top - S.t.y) / S.t.s };
}
let pickTimer = null, pickSeq = 0;
// wheel zoom about the cursor and press-drag pan, for these panes and "Add photo"'s (addphoto.js)
function zoomed(t, el, ev, least) {  // the transform after a wheel event over el
  const r = el.getBoundingClientRect(), px = ev.clientX - r.left, py = ev.clientY - r.top;
  const s = Math.min(40, Math.max(least, t.s * Math.exp(-ev.deltaY * 0.0015)));
  return { s, x: px - (px - t.x) * (s / t.s), y: py - (py - t.y) * (s / t.s) };
}
// a press that moves more than 3 px pans the transform getT() gives (apply() shows it); else its release is click(e)
function panOrClick(ev, getT, apply, click) {
  const start = { x: ev.clientX, y: ev.clientY, tx: getT().x, ty: getT().y };
  let moved = false;
  const move = (e) => {
    const dx = e.clientX - start.x, dy = e.clientY - start.y;
    if (Math.abs(dx) + Math.abs(dy) > 3) moved = true;
    if (moved) { getT().x = start.tx + dx; getT().y = start.ty + dy; apply(); }
  };
  const up = (e) => {
    window.removeEventListener("mousemove", move); window.removeEventListener("mouseup", up);
    if (!moved) click(e);
  };
  window.addEventListener("mousemove", move); window.addEventListener("mouseup", up);
}
for (const pane of panes) {
  pane.addEventListener("wheel", (ev) => {
    ev.preventDefault(); S.t = zoomed(S.t, pane, ev, 0.05); S.fitted = false; applyTransform();
  }, { passive: false });
  pane.addEventListener("mousedown", (ev) => {
    if (ev.button !== 0 || !S.shot) return;
    panOrClick(ev, () => S.t, () => { S.fitted = false; applyTransform(); }, (e) => {
      const p = toImage(pane, e);
      if (S.offsetFor !== null) { measureOffset(p.x, p.y).catch(() => {}); return; }
      if (S.selected !== null) { select(null); return; }  // the first click closes the editor (saved), the next places a marker
      if (p.x >= 0 && p.y >= 0 && p.x < S.shot.width && p.y < S.shot.height) addMarker(p.x, p.y);
    });
  });
  pane.addEventListener("mousemove", (ev) => {
    if (!S.shot) return;
    const p = toImage(pane, ev), tip = $("#tooltip"), vr = $("#viewport").getBoundingClientRect();
    tip.style.left = ev.clientX - vr.left + 14 + "px"; tip.style.top = ev.clientY - vr.top + 14 + "px";
    if (p.x < 0 || p.y < 0 || p.x >= S.shot.width || p.y >= S.shot.height) { tip.style.display = "none"; return; }
    clearTimeout(pickTimer);
    pickTimer = setTimeout(async () => {
      const seq = ++pickSeq;
      const hit = await api("GET", `api/shots/${enc(S.shot.name)}/pick?x=${p.x.toFixed(1)}&y=${p.y.toFixed(1)}`);
      if (seq !== pickSeq) return;
      // an imported element: its IFC class, name and storey after the id (GlobalId)
      const element = [hit.ifc_class, hit.name, hit.storey].filter(Boolean).join(", ");
      tip.textContent = hit.part ? `${hit.instance}${element ? ` (${element})` : ""} - ${hit.distance.toFixed(2)} m` : "no CAD";
      tip.style.display = "block";
    }, 60);
  });
  pane.addEventListener("mouseleave", () => { clearTimeout(pickTimer); pickSeq++; $("#tooltip").style.display = "none"; });
}

// -- controls --------------------------------------------------------------------------------
$("#opacity").addEventListener("input", (ev) => { S.opacity = Number(ev.target.value); applyView(); });
$("#intensity").addEventListener("input", (ev) => {
  S.level = Number(ev.target.value); $("#intensity-out").textContent = S.info.intensities[S.level]; loadRender();
});
$("#view").addEventListener("change", (ev) => { S.view = ev.target.value; applyView(); fit(); });
$("#edges").addEventListener("change", (ev) => { S.edges = ev.target.checked; applyView(); });
$("#reset-view").onclick = fit;
window.addEventListener("resize", fit);
// the toolbar wraps when its status text or mode buttons grow, and the panes shrink under a fitted
// image: refit then, unless the planner has zoomed or panned since the last fit
new ResizeObserver(() => { if (S.fitted) fit(); }).observe($("#viewport"));

function addShotItem(shot) {  // also for a shot added by "Add photo" (addphoto.js)
  const li = document.createElement("li");
  li.dataset.name = shot.name;
  const err = shot.error_px == null ? "error n/a" : `error ${shot.error_px.toFixed(2)} px`;
  li.innerHTML = `<img alt=""><div><b></b><br><small></small></div>`;
  $("img", li).src = `api/shots/${enc(shot.name)}/thumb.png`;
  $("b", li).textContent = shot.name; $("small", li).textContent = err;
  li.onclick = () => selectShot(shot);
  $("#shot-list").appendChild(li);
}

async function start() {
  S.info = await api("GET", "api/info");
  for (const mode of S.info.modes) {
    const b = document.createElement("button");
    b.textContent = S.info.labels[mode]; b.dataset.mode = mode; b.type = "button";
    b.onclick = () => { S.mode = mode; for (const x of $$("#modes button")) x.classList.toggle("active", x === b); loadRender(); };
    b.classList.toggle("active", mode === S.mode);
    $("#modes").appendChild(b);
  }
  for (const c of S.info.categories) $("#ed-category").add(new Option(c, c));
  for (const v of S.info.viewpoints) $("#live-start").add(new Option(`from viewpoint ${v}`, `view:${v}`));
  if (S.info.markers) $("#live-start").add(new Option("from the markers in view", "markers"));
  $("#intensity-out").textContent = S.info.intensities[S.level];
  S.shots = await api("GET", "api/shots");
  for (const shot of S.shots) addShotItem(shot);
  for (const link of $$("#exports a")) link.onclick = (e) => { e.preventDefault(); exportFile(link); };
  $("#import-bcf").onchange = importBcf;
  applyView();
  const wanted = new URLSearchParams(location.search).get("shot");
  await selectShot(S.shots.find((s) => s.name === wanted) || S.shots[0]);
  document.body.dataset.ready = "1";
}
start();
