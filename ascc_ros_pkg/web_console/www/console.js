// ASCCbot browser console: the page side of web_console's protocol (src/web_console/protocol.py).
// Plain JavaScript, no libraries, no build step.
"use strict";
(function () {
  const $ = (id) => document.getElementById(id);
  const SEND_PERIOD_MS = 50;       // drive commands repeat this often while held (lease ~200 ms)
  const PING_PERIOD_MS = 1000;
  const LINK_LOST_MS = 3000;       // no pong for this long: the link is lost, reconnect
  const state = {
    ws: null, hello: null, rtt: null, lastPong: 0, retryMs: 500, frames: 0,
    frameAgeS: null, frameAt: 0, videoUrl: null, map: null, mapImg: null, status: null,
    stick: null, keys: new Set(), driving: false, token: "",
  };
  window.consoleState = state;     // read by the browser test

  // -- link -------------------------------------------------------------------------
  function setLink(text, cls) { const el = $("link"); el.textContent = text; el.className = cls; }

  function connect() {
    const proto = location.protocol === "https:" ? "wss:" : "ws:";
    const ws = new WebSocket(proto + "//" + location.host + "/ws");
    ws.binaryType = "arraybuffer";
    state.ws = ws;
    setLink("connecting", "warn");
    ws.onopen = () => {
      state.retryMs = 500; state.lastPong = performance.now();
      setLink("connected", "ok");
      if (state.token) send({ type: "auth", token: state.token });
    };
    ws.onclose = () => {
      if (state.ws !== ws) return;
      state.ws = null; state.driving = false;
      setLink("reconnecting in " + (state.retryMs / 1000).toFixed(1) + " s", "bad");
      setTimeout(connect, state.retryMs);
      state.retryMs = Math.min(state.retryMs * 2, 4000);
    };
    ws.onmessage = (ev) => {
      if (typeof ev.data === "string") onJson(JSON.parse(ev.data)); else onBinary(ev.data);
    };
  }

  function send(obj) {
    if (state.ws && state.ws.readyState === WebSocket.OPEN) state.ws.send(JSON.stringify(obj));
  }

  setInterval(() => {
    if (!state.ws || state.ws.readyState !== WebSocket.OPEN) return;
    if (performance.now() - state.lastPong > LINK_LOST_MS) {   // silent network: start over
      setLink("lost", "bad"); state.ws.close(); return;
    }
    send({ type: "ping", id: performance.now() });
  }, PING_PERIOD_MS);

  function onJson(m) {
    if (m.type === "pong") {
      state.lastPong = performance.now(); state.rtt = performance.now() - m.id;
      $("rtt").textContent = state.rtt.toFixed(0) + " ms";
    } else if (m.type === "hello") {
      state.hello = m;
    } else if (m.type === "auth") {
      message(m.ok ? "token accepted: you may drive" : "wrong token");
    } else if (m.type === "error") {
      message(m.message);
    } else if (m.type === "status") {
      state.status = m; showStatus(m); drawMap();
    }
  }

  function message(text) { $("message").textContent = text; }

  // -- binary: kind, uint32 header length, JSON header, payload ----------------------
  function onBinary(buf) {
    const view = new DataView(buf);
    const kind = String.fromCharCode(view.getUint8(0));
    const n = view.getUint32(1);
    const header = JSON.parse(new TextDecoder().decode(new Uint8Array(buf, 5, n)));
    const payload = new Uint8Array(buf, 5 + n);
    if (kind === "V") onVideo(header, payload); else if (kind === "M") onMap(header, payload);
  }

  function onVideo(header, jpeg) {
    const url = URL.createObjectURL(new Blob([jpeg], { type: "image/jpeg" }));
    const img = $("video");
    const old = state.videoUrl;
    img.onload = () => { if (old) URL.revokeObjectURL(old); };
    img.src = url; state.videoUrl = url;
    state.frames += 1;
    // glass-to-glass: age when the server sent it + half the round trip
    state.frameAgeS = header.age_s + (state.rtt ? state.rtt / 2000 : 0);
    state.frameAt = performance.now();
  }

  function frameAge() {
    return state.frameAgeS === null ? null
      : state.frameAgeS + (performance.now() - state.frameAt) / 1000;
  }

  setInterval(() => {
    const age = frameAge(), el = $("age"), box = $("videobox");
    const limit = state.hello ? state.hello.max_frame_age_s : 0.5;
    if (age === null) { el.textContent = "no video"; el.className = "bad"; return; }
    const stale = age > limit;
    el.textContent = (stale ? "STALE " : "") + "frame age " + (age * 1000).toFixed(0) + " ms";
    el.className = stale ? "bad" : "";
    box.classList.toggle("stale", stale);
  }, 100);

  // -- map --------------------------------------------------------------------------
  function onMap(header, png) {
    const img = new Image();
    img.onload = () => { state.map = header; state.mapImg = img; drawMap(); };
    img.src = URL.createObjectURL(new Blob([png], { type: "image/png" }));
  }

  function mapScale() {          // canvas pixels per map cell (fit, keep aspect)
    const c = $("map"), m = state.map;
    return Math.min(c.width / m.width, c.height / m.height);
  }

  function worldToCanvas(x, y) {
    const m = state.map, s = mapScale();
    return [(x - m.origin_x) / m.resolution * s, (m.height - (y - m.origin_y) / m.resolution) * s];
  }

  function canvasToWorld(px, py) {
    const m = state.map, s = mapScale();
    return [m.origin_x + px / s * m.resolution, m.origin_y + (m.height - py / s) * m.resolution];
  }
  window.consoleWorldToCanvas = worldToCanvas;   // the browser test clicks through it

  function drawMap() {
    if (!state.map) return;
    const c = $("map"), g = c.getContext("2d"), m = state.map, s = mapScale();
    g.fillStyle = "#555"; g.fillRect(0, 0, c.width, c.height);
    g.imageSmoothingEnabled = false;
    g.drawImage(state.mapImg, 0, 0, m.width * s, m.height * s);
    const st = state.status;
    if (!st) return;
    if (st.path && st.path.length > 1) {
      g.strokeStyle = "#0a0"; g.lineWidth = 2; g.beginPath();
      st.path.forEach((p, i) => { const q = worldToCanvas(p[0], p[1]); i ? g.lineTo(q[0], q[1]) : g.moveTo(q[0], q[1]); });
      g.stroke();
    }
    if (st.goal) {
      const q = worldToCanvas(st.goal.x, st.goal.y);
      g.strokeStyle = "#f0f"; g.lineWidth = 2; g.beginPath(); g.arc(q[0], q[1], 6, 0, 2 * Math.PI); g.stroke();
    }
    if (st.pose) {
      const q = worldToCanvas(st.pose[0], st.pose[1]), a = st.pose[2], r = Math.max(6, 0.17 / m.resolution * s);
      g.fillStyle = "#08f"; g.beginPath();
      g.moveTo(q[0] + r * 1.6 * Math.cos(a), q[1] - r * 1.6 * Math.sin(a));
      g.lineTo(q[0] + r * Math.cos(a + 2.4), q[1] - r * Math.sin(a + 2.4));
      g.lineTo(q[0] + r * Math.cos(a - 2.4), q[1] - r * Math.sin(a - 2.4));
      g.closePath(); g.fill();
    }
  }

  $("map").addEventListener("click", (ev) => {
    if (!state.map) { message("no map yet"); return; }
    const c = $("map"), r = c.getBoundingClientRect();
    const px = (ev.clientX - r.left) * c.width / r.width, py = (ev.clientY - r.top) * c.height / r.height;
    const w = canvasToWorld(px, py), pose = state.status && state.status.pose;
    const yaw = pose ? Math.atan2(w[1] - pose[1], w[0] - pose[0]) : 0;
    send({ type: "goal", x: w[0], y: w[1], yaw: yaw });
  });
  $("cancel").onclick = () => send({ type: "cancel" });

  // -- status -----------------------------------------------------------------------
  function showStatus(st) {
    const b = st.battery;
    $("battery").textContent = b && b.percent !== null ? b.percent.toFixed(0) + " %" + (b.charging ? " (charging)" : "") : "-";
    const h = st.hazards;
    const bump = h ? [h.bump_left ? "left" : "", h.bump_right ? "right" : ""].filter(Boolean).join("+") : "";
    $("bumpers").textContent = h ? (bump || "clear") + (h.cliff ? " CLIFF" : "") + (h.wheeldrop ? " WHEELDROP" : "") : "-";
    $("bumpers").className = h && (bump || h.cliff || h.wheeldrop) ? "bad" : "ok";
    $("mode").textContent = st.estop ? "E-STOP" : st.mode;
    $("mode").className = st.estop ? "bad" : "";
    $("gesture").textContent = st.gesture;
    $("gesture").className = st.gesture === "coming" || st.gesture === "backing" ? "warn" : "";
    $("driver").textContent = st.driver || "nobody";
    $("pages").textContent = st.pages;
    $("estop").classList.toggle("on", st.estop);
    $("goal").textContent = st.goal ? "goal (" + st.goal.x.toFixed(2) + ", " + st.goal.y.toFixed(2) + ") " + st.goal.state : "click the map to send a goal";
  }

  $("estop").onclick = () => { stopDriving(); send({ type: "estop", on: true }); };
  $("rearm").onclick = () => send({ type: "estop", on: false });
  $("auth").onclick = () => { state.token = $("token").value; send({ type: "auth", token: state.token }); };
  $("speed").oninput = () => { $("speedval").textContent = $("speed").value + " %"; };
  const fromHash = new URLSearchParams(location.hash.slice(1)).get("token");
  if (fromHash) { state.token = fromHash; $("token").value = fromHash; }

  // -- drive: joystick and keyboard, repeated while held, released at once ------------
  const stick = $("joystick");
  function drawStick() {
    const g = stick.getContext("2d"), R = stick.width / 2;
    g.clearRect(0, 0, stick.width, stick.height);
    g.strokeStyle = "#888"; g.beginPath(); g.arc(R, R, R - 2, 0, 2 * Math.PI); g.stroke();
    const p = state.stick || [0, 0];
    g.fillStyle = state.stick ? "#08f" : "#666";
    g.beginPath(); g.arc(R + p[0] * (R - 20), R + p[1] * (R - 20), 18, 0, 2 * Math.PI); g.fill();
  }
  function stickAt(ev) {
    const r = stick.getBoundingClientRect(), R = r.width / 2;
    let x = (ev.clientX - r.left - R) / (R - 20), y = (ev.clientY - r.top - R) / (R - 20);
    const n = Math.hypot(x, y); if (n > 1) { x /= n; y /= n; }
    state.stick = [x, y]; drawStick();
  }
  stick.addEventListener("pointerdown", (ev) => { stick.setPointerCapture(ev.pointerId); stickAt(ev); });
  stick.addEventListener("pointermove", (ev) => { if (state.stick) stickAt(ev); });
  const letGo = () => { if (state.stick) { state.stick = null; drawStick(); } };
  stick.addEventListener("pointerup", letGo);
  stick.addEventListener("pointercancel", letGo);
  stick.addEventListener("lostpointercapture", letGo);

  const KEYS = { ArrowUp: [0, -1], KeyW: [0, -1], ArrowDown: [0, 1], KeyS: [0, 1],
                 ArrowLeft: [-1, 0], KeyA: [-1, 0], ArrowRight: [1, 0], KeyD: [1, 0] };
  document.addEventListener("keydown", (ev) => {
    if (ev.target.tagName === "INPUT" || !(ev.code in KEYS)) return;
    state.keys.add(ev.code); ev.preventDefault();
  });
  document.addEventListener("keyup", (ev) => { state.keys.delete(ev.code); });
  window.addEventListener("blur", () => { state.keys.clear(); letGo(); });

  function demand() {            // [forward, left] in -1..1
    if (state.stick) return [-state.stick[1], -state.stick[0]];
    let f = 0, l = 0;
    state.keys.forEach((k) => { f -= KEYS[k][1]; l -= KEYS[k][0]; });
    return state.keys.size ? [Math.max(-1, Math.min(1, f)), Math.max(-1, Math.min(1, l))] : null;
  }
  function stopDriving() { if (state.driving) { state.driving = false; send({ type: "release" }); } }

  setInterval(() => {
    const d = demand();
    if (!d || !state.hello) { stopDriving(); return; }
    const k = $("speed").value / 100;
    state.driving = true;
    send({ type: "drive", linear: d[0] * k * state.hello.max_linear_mps,
           angular: d[1] * k * state.hello.max_angular_rps });
  }, SEND_PERIOD_MS);

  drawStick();
  connect();
})();
