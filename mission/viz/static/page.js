// The mission page: one script for a static tree, a recorded log (scrubbing) and a live run (server-sent events).
// The tree SVG is drawn by Python (mission.viz.svg); this script only changes node classes and text.
(function () {
  "use strict";
  const DATA = JSON.parse(document.getElementById("mission-data").textContent);
  const STATE_COLOURS = DATA.state_colours || {};
  const $ = (id) => document.getElementById(id);
  const app = {
    mode: DATA.mode, header: DATA.header, ticks: DATA.ticks || [], cursor: -1,
    nodes: [], edges: {}, selected: null, playing: null, follow: true, lastCamera: 0, cameraTick: -1,
  };
  window.missionApp = app; // for tests and the console

  function esc(s) {
    return String(s).replace(/[&<>"]/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" })[c]);
  }
  function fmt(v, digits) { return v === null || v === undefined ? "—" : Number(v).toFixed(digits); }

  // ---------------------------------------------------------------- tree
  function bindTree() {
    const svg = document.querySelector("#tree svg");
    app.nodes = []; app.edges = {};
    if (!svg) return;
    svg.removeAttribute("width"); svg.removeAttribute("height");
    svg.setAttribute("preserveAspectRatio", "xMidYMin meet");
    app.fullBox = svg.getAttribute("viewBox").split(/\s+/).map(Number);
    document.querySelectorAll("#tree .node").forEach((g) => {
      const id = Number(g.dataset.id);
      const kind = Array.from(g.classList).find((c) => c.startsWith("k-")) || "k-Action";
      app.nodes[id] = { g: g, kind: kind, fb: g.querySelector("text.fb"), title: g.querySelector("title"),
                        base: g.querySelector("title") ? g.querySelector("title").textContent.split("\nstatus:")[0] : "" };
      g.addEventListener("click", (ev) => { ev.stopPropagation(); select(id); });
    });
    document.querySelectorAll("#tree .edge").forEach((p) => { app.edges[Number(p.dataset.child)] = p; });
    if (app.header && app.header.tree) $("tree-name").textContent = app.header.tree.name;
  }

  function truncate(text, n) { return text.length > n ? text.slice(0, Math.max(0, n - 1)) + "…" : text; }

  function applyNodes(rows) {
    rows.forEach((row, id) => {
      const n = app.nodes[id];
      if (!n) return;
      const status = row[0] || "INVALID";
      const cls = "node " + n.kind + " st-" + status + (app.selected === id ? " selected" : "");
      if (n.g.getAttribute("class") !== cls) n.g.setAttribute("class", cls);
      if (n.fb) n.fb.textContent = truncate(row[1] || "", Number(n.g.dataset.fbmax || 40));
      if (n.title) {
        let t = n.base + "\nstatus: " + status;
        if (row[1]) t += "\nfeedback: " + row[1];
        if (row[2] !== null && row[2] !== undefined) t += "\ntick: " + Math.round(row[2]) + " µs";
        n.title.textContent = t;
      }
      const e = app.edges[id];
      if (e) e.setAttribute("class", "edge st-" + status);
    });
  }

  // ---------------------------------------------------------------- pan and zoom
  function setView(box) { const svg = document.querySelector("#tree svg"); if (svg) { app.view = box; svg.setAttribute("viewBox", box.join(" ")); } }
  function fit() { if (app.fullBox) setView(app.fullBox.slice()); }
  function zoom(f, cx, cy) {
    if (!app.view) return;
    const [x, y, w, h] = app.view;
    cx = cx === undefined ? x + w / 2 : cx; cy = cy === undefined ? y + h / 2 : cy;
    setView([cx - (cx - x) * f, cy - (cy - y) * f, w * f, h * f]);
  }
  function svgPoint(ev) {
    const svg = document.querySelector("#tree svg");
    const pt = svg.createSVGPoint(); pt.x = ev.clientX; pt.y = ev.clientY;
    return pt.matrixTransform(svg.getScreenCTM().inverse());
  }
  function bindPanZoom() {
    const host = $("tree");
    host.addEventListener("wheel", (ev) => { ev.preventDefault(); const p = svgPoint(ev); zoom(ev.deltaY > 0 ? 1.15 : 1 / 1.15, p.x, p.y); }, { passive: false });
    let drag = null;
    host.addEventListener("mousedown", (ev) => { drag = { p: svgPoint(ev), v: app.view.slice() }; host.style.cursor = "grabbing"; });
    window.addEventListener("mouseup", () => { drag = null; host.style.cursor = ""; });
    window.addEventListener("mousemove", (ev) => {
      if (!drag) return;
      const p = svgPoint(ev);
      setView([app.view[0] - (p.x - drag.p.x), app.view[1] - (p.y - drag.p.y), app.view[2], app.view[3]]);
    });
    $("fit").onclick = fit; $("zoom-in").onclick = () => zoom(1 / 1.25); $("zoom-out").onclick = () => zoom(1.25);
    $("tree").addEventListener("click", () => select(null));
  }

  // ---------------------------------------------------------------- side panels
  function nodeInfo(id) {
    const src = app.header && app.header.tree;
    let i = 0, found = null;
    (function walk(n) { if (found) return; if (i === id) { found = n; return; } i++; (n.children || []).forEach(walk); })(src || {});
    return found;
  }

  function select(id) {
    if (app.selected !== null && app.nodes[app.selected]) app.nodes[app.selected].g.classList.remove("selected");
    app.selected = id;
    if (id !== null && app.nodes[id]) app.nodes[id].g.classList.add("selected");
    renderDetails();
  }

  function renderDetails() {
    const rec = app.ticks[app.cursor];
    const rows = [];
    if (app.selected !== null) {
      const info = nodeInfo(app.selected) || {};
      const row = rec ? rec.nodes[app.selected] || [] : [];
      rows.push(["node", "<b>" + esc(info.name || "?") + "</b> <span class='muted'>" + esc(info.type || "") + " · " + esc(info.kind || "") + "</span>"]);
      Object.entries(info.ports || {}).forEach(([k, v]) => rows.push([k, "<code>" + esc(v) + "</code>"]));
      Object.entries(info.defaults || {}).forEach(([k, v]) => rows.push([k, "<code>" + esc(v) + "</code> <span class='muted'>default</span>"]));
      if (rec) {
        rows.push(["status", "<b>" + esc(row[0] || "INVALID") + "</b>"]);
        rows.push(["feedback", esc(row[1] || "—")]);
        rows.push(["own tick", row[2] === null || row[2] === undefined ? "not ticked" : Math.round(row[2]) + " µs"]);
        const bb = rec.bb || {}; const key = String(app.selected);
        rows.push(["read", ((bb.read || {})[key] || []).map((k) => "<code>" + esc(k) + "</code>").join(" ") || "—"]);
        rows.push(["wrote", ((bb.write || {})[key] || []).map((k) => "<code>" + esc(k) + "</code>").join(" ") || "—"]);
      }
    } else if (rec) {
      rows.push(["state", "<b>" + esc(rec.state || "—") + "</b>" + (rec.reason ? " <span class='muted'>" + esc(rec.reason) + "</span>" : "")]);
      rows.push(["active", esc((rec.active || []).join(" › "))]);
      rows.push(["tick time", Math.round(rec.tick_us || 0) + " µs"]);
      if (rec.robot) rows.push(["robot", "x " + fmt(rec.robot[0], 2) + "  y " + fmt(rec.robot[1], 2) + "  θ " + fmt(rec.robot[2] * 57.2958, 0) + "°"]);
      if (rec.goal) rows.push(["goal", "x " + fmt(rec.goal[0], 2) + "  y " + fmt(rec.goal[1], 2)]);
      if (rec.twist) rows.push(["twist", "v " + fmt(rec.twist[0], 2) + " m/s  ω " + fmt(rec.twist[1], 2) + " rad/s"]);
      Object.entries(rec.tracks || {}).forEach(([k, t]) => rows.push(["track " + esc(k), (t.visible ? "visible" : "not visible") + ", misses " + t.misses]));
      (rec.detections || []).forEach((d) => rows.push(["detection", esc(d.source) + " " + (d.id !== null ? "id " + d.id : esc(d.label || "")) + " at " + fmt(d.distance, 2) + " m"]));
    } else {
      rows.push(["tree", esc((app.header && app.header.tree_file) || "")]);
    }
    $("details").innerHTML = "<table>" + rows.map((r) => "<tr><td class='k'>" + r[0] + "</td><td>" + r[1] + "</td></tr>").join("") + "</table>";
  }

  function svgEl(tag, attrs) {
    const el = document.createElementNS("http://www.w3.org/2000/svg", tag);
    Object.entries(attrs).forEach(([k, v]) => el.setAttribute(k, v));
    return el;
  }

  function setupMap() {
    const m = app.header && app.header.map;
    const svg = $("map");
    svg.innerHTML = "";
    if (!m || !m.png) { svg.style.display = "none"; $("map-empty").style.display = ""; return; }
    svg.style.display = "block"; $("map-empty").style.display = "none";
    svg.setAttribute("viewBox", "0 0 " + m.width + " " + m.height);
    svg.appendChild(svgEl("image", { href: "data:image/png;base64," + m.png, width: m.width, height: m.height }));
    ["trail-target", "trail-robot"].forEach((id, i) => svg.appendChild(svgEl("polyline", { id: id, fill: "none", stroke: i ? "#8ab4f8" : "#f28b82", "stroke-width": 2 })));
    svg.appendChild(svgEl("path", { id: "m-goal", stroke: "#e37400", "stroke-width": 2.5, fill: "none" }));
    svg.appendChild(svgEl("g", { id: "m-est" }));
    svg.appendChild(svgEl("g", { id: "m-target" }));
    svg.appendChild(svgEl("g", { id: "m-robot" }));
  }

  function px(x, y) {
    const a = app.header.map.affine;
    return [a[0][0] * x + a[0][1] * y + a[0][2], a[1][0] * x + a[1][1] * y + a[1][2]];
  }

  function drawPose(g, pose, colour, r) {
    g.innerHTML = "";
    if (!pose) return;
    const k = app.header.map.px_per_m;
    const [u, v] = px(pose[0], pose[1]);
    const [tu, tv] = px(pose[0] + 2.2 * r * Math.cos(pose[2]), pose[1] + 2.2 * r * Math.sin(pose[2]));
    const rp = Math.max(3, r * k);
    g.appendChild(svgEl("circle", { cx: u, cy: v, r: rp, fill: colour, stroke: "#fff", "stroke-width": 1.2 }));
    g.appendChild(svgEl("line", { x1: u, y1: v, x2: tu, y2: tv, stroke: "#282828", "stroke-width": Math.max(1.5, rp / 3) }));
  }

  function updateMap(rec) {
    const m = app.header && app.header.map;
    if (!m || !m.png || !rec) return;
    const truth = rec.truth || {};
    const robot = truth.robot || rec.robot;
    const from = Math.max(0, app.cursor - 600);
    const rpts = [], tpts = [];
    for (let i = from; i <= app.cursor; i++) {
      const r = app.ticks[i]; if (!r) continue;
      const rp = (r.truth && r.truth.robot) || r.robot; if (rp) rpts.push(px(rp[0], rp[1]).join(","));
      const tp = r.truth && r.truth.target; if (tp) tpts.push(px(tp[0], tp[1]).join(","));
    }
    $("trail-robot").setAttribute("points", rpts.join(" "));
    $("trail-target").setAttribute("points", tpts.join(" "));
    const goal = $("m-goal");
    if (rec.goal) { const [u, v] = px(rec.goal[0], rec.goal[1]); goal.setAttribute("d", `M${u - 6},${v} H${u + 6} M${u},${v - 6} V${v + 6}`); }
    else goal.setAttribute("d", "");
    const est = $("m-est"); est.innerHTML = "";
    Object.values(rec.tracks || {}).forEach((t) => {
      const [u, v] = px(t.xy[0], t.xy[1]);
      est.appendChild(svgEl("circle", { cx: u, cy: v, r: 6, fill: "none", stroke: "#d93025", "stroke-width": 1.5, "stroke-dasharray": t.visible ? "" : "3 2" }));
    });
    drawPose($("m-target"), truth.target, "#d93025", 0.15);
    drawPose($("m-robot"), robot, "#1a73e8", 0.2);
  }

  function updateCamera(rec) {
    if (app.mode !== "live" || !rec) return;
    const now = Date.now();
    if (rec.tick === app.cameraTick || now - app.lastCamera < 200) return;
    app.lastCamera = now; app.cameraTick = rec.tick;
    const img = $("camera");
    const probe = new Image();
    probe.onload = () => { img.src = probe.src; img.style.display = "block"; $("camera-empty").style.display = "none"; };
    probe.src = "/camera.jpg?tick=" + rec.tick;
  }

  // ---------------------------------------------------------------- one tick on screen
  function show(index) {
    if (!app.ticks.length) return;
    index = Math.max(0, Math.min(app.ticks.length - 1, index));
    app.cursor = index;
    const rec = app.ticks[index];
    applyNodes(rec.nodes || []);
    const pill = $("state-pill");
    pill.textContent = rec.state || "—";
    pill.style.background = STATE_COLOURS[rec.state] || "#5f6368";
    $("clock").textContent = fmt(rec.t, 1) + " s";
    $("tick").textContent = rec.tick;
    const rs = $("root-status"); rs.textContent = rec.status || "—"; rs.className = "st-text " + (rec.status || "");
    const dist = rec.truth && rec.truth.distance;
    $("distance").textContent = dist === undefined || dist === null ? "—" : fmt(dist, 2) + " m";
    $("active-branch").textContent = (rec.active || []).slice(-4).join(" › ");
    $("det-count").textContent = (rec.detections || []).length + " detection(s)";
    const slider = $("slider");
    slider.max = app.ticks.length - 1; slider.value = index;
    $("scrub-label").textContent = "tick " + rec.tick + " · " + fmt(rec.t, 1) + " s  (" + (index + 1) + "/" + app.ticks.length + ")";
    updateMap(rec);
    updateCamera(rec);
    renderDetails();
    document.body.dataset.tick = rec.tick;
  }

  // ---------------------------------------------------------------- scrubbing and playback
  function bindScrub() {
    $("slider").addEventListener("input", (ev) => { app.follow = false; $("follow").checked = false; show(Number(ev.target.value)); });
    $("follow").addEventListener("change", (ev) => { app.follow = ev.target.checked; if (app.follow) show(app.ticks.length - 1); });
    $("play").onclick = () => {
      if (app.playing) { clearInterval(app.playing); app.playing = null; $("play").textContent = "▶"; return; }
      app.follow = false; $("follow").checked = false;
      if (app.cursor >= app.ticks.length - 1) show(0);
      $("play").textContent = "❚❚";
      app.playing = setInterval(() => {
        if (app.cursor >= app.ticks.length - 1) { $("play").onclick(); return; }
        show(app.cursor + 1);
      }, 100);
    };
    document.addEventListener("keydown", (ev) => {
      if (ev.key === "ArrowRight") show(app.cursor + 1);
      else if (ev.key === "ArrowLeft") show(app.cursor - 1);
      else return;
      app.follow = false; $("follow").checked = false;
    });
  }

  function loadLogText(text) {
    const lines = text.split("\n").filter((l) => l.trim());
    const header = JSON.parse(lines[0]);
    if (header.kind !== "header") throw new Error("not a mission tick log: the first line is not a header");
    const ticks = [];
    lines.slice(1).forEach((l) => { try { const o = JSON.parse(l); if (o.nodes) ticks.push(o); } catch (e) { /* cut-off last line */ } });
    return fetch("/api/tree.svg", { method: "POST", body: JSON.stringify(header.tree) })
      .then((r) => { if (!r.ok) throw new Error("the server could not draw this tree"); return r.text(); })
      .then((svg) => {
        if (app.source) app.source.close();
        app.mode = "playback"; document.body.className = "mode-playback"; $("mode-badge").textContent = "log";
        app.header = header; app.ticks = ticks;
        $("tree").innerHTML = svg; bindTree(); fit(); setupMap(); show(0);
      });
  }

  // ---------------------------------------------------------------- live
  function connect() {
    const last = app.ticks.length ? app.ticks[app.ticks.length - 1].tick : -1;
    const src = new EventSource("/events?after=" + last);
    app.source = src;
    let pending = false;
    src.addEventListener("tick", (ev) => {
      const rec = JSON.parse(ev.data);
      if (app.ticks.length && rec.tick <= app.ticks[app.ticks.length - 1].tick) return;
      app.ticks.push(rec);
      if (pending) return;
      pending = true; // many ticks can arrive at once: draw the newest, at most every 40 ms
      setTimeout(() => {
        pending = false;
        if (app.follow) show(app.ticks.length - 1);
        else { $("slider").max = app.ticks.length - 1; }
      }, 40);
    });
    src.addEventListener("header", (ev) => {
      const h = JSON.parse(ev.data);
      // a new run or a new tree in this run (an action server's goal): the page of that one
      if (!app.header || h.created !== app.header.created || h.generation !== app.header.generation) location.reload();
    });
    src.addEventListener("end", () => {
      src.close(); // the server stops after the run: do not reconnect
      $("conn").textContent = "run finished"; $("mode-badge").textContent = "finished";
    });
    src.onopen = () => { $("conn").textContent = "connected"; };
    src.onerror = () => { $("conn").textContent = "disconnected — retrying"; };
  }

  // ---------------------------------------------------------------- start
  bindTree(); fit(); bindPanZoom(); bindScrub(); setupMap();
  $("log-file").addEventListener("change", (ev) => {
    const f = ev.target.files[0]; if (!f) return;
    f.text().then(loadLogText).catch((e) => { $("conn").textContent = String(e.message || e); });
  });
  if (app.ticks.length) {
    const want = DATA.tick;
    let i = app.ticks.length - 1;
    if (want !== null && want !== undefined) { const j = app.ticks.findIndex((r) => r.tick === want); if (j >= 0) i = j; }
    app.follow = app.mode === "live";
    show(i);
  } else {
    renderDetails();
  }
  if (app.mode === "live") connect();
  document.body.dataset.ready = "1";
})();
