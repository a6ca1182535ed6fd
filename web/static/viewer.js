// The live viewer of transientd (docs/web.md): frames over the gateway's WebSocket, colour-mapped
// on the GPU (WebGL2: the half floats go into a texture as they came), pixel transients,
// stats, recording, calibration and settings through the gateway's calls.
"use strict";

const SPEED_OF_LIGHT = 299792458;  // m/s
const FLAG_BITS = [  // transient.v1 FLAGS (docs/protocol.md)
  [1, "biased", "#4e79a7"], [2, "invalid input", "#e15759"], [4, "no return", "#bab0ac"],
  [8, "saturated", "#f28e2b"], [16, "outlier filled", "#76b7b2"], [32, "ambiguous", "#b07aa1"],
  [64, "low amplitude", "#59a14f"],
];
const UNITS = { range: "m", amplitude: "", slices: "/rad", flags: "" };

const $ = (id) => document.getElementById(id);

const state = {
  socket: null,
  nextId: 1,
  pending: new Map(),      // id -> {resolve, reject, progress}
  frame: null,             // the frame shown: {header, images: Map(name -> {values, type, tofNs})}
  width: 0, height: 0,
  product: "range",
  slice: 0,
  playing: false,
  scales: { range: null, amplitude: null, slices: null },  // null: automatic at the next frame
  colourMap: null,
  arrivals: [],            // times of the last frames, for the rate
  missed: 0,               // frames the daemon dropped for the gateway
  info: null,
};

// ---------------------------------------------------------------- the GPU picture
const gl = $("view").getContext("webgl2", { preserveDrawingBuffer: true, antialias: false });
let program = null, valueTexture = null, mapTexture = null;

function compile(type, source) {
  const shader = gl.createShader(type);
  gl.shaderSource(shader, source);
  gl.compileShader(shader);
  if (!gl.getShaderParameter(shader, gl.COMPILE_STATUS)) {
    throw new Error(gl.getShaderInfoLog(shader));
  }
  return shader;
}

function setUpGpu() {
  if (!gl) { showBanner("This browser has no WebGL2: the images cannot be drawn."); return; }
  const vertex = `#version 300 es
    in vec2 corner; out vec2 uv;
    void main() { uv = corner * 0.5 + 0.5; gl_Position = vec4(corner, 0.0, 1.0); }`;
  const fragment = `#version 300 es
    precision highp float;
    uniform sampler2D values; uniform sampler2D colourMap;
    uniform float lo; uniform float hi; uniform int flags; uniform vec3 noValue;
    uniform vec3 flagColours[7];
    in vec2 uv; out vec4 colour;
    void main() {
      vec2 at = vec2(uv.x, 1.0 - uv.y);  // the image's row 0 at the top
      float v = texture(values, at).r;
      if (flags == 1) {
        int bits = int(v * 255.0 + 0.5);
        vec3 c = vec3(0.15);  // no flag: dark
        for (int i = 6; i >= 0; --i) if ((bits & (1 << i)) != 0) c = flagColours[i];
        colour = vec4(c, 1.0);
        return;
      }
      if (isnan(v) || isinf(v)) { colour = vec4(noValue, 1.0); return; }
      float t = clamp((v - lo) / (hi - lo), 0.0, 1.0);
      colour = vec4(texture(colourMap, vec2((floor(t * 255.0 + 0.5) + 0.5) / 256.0, 0.5)).rgb, 1.0);
    }`;
  program = gl.createProgram();
  gl.attachShader(program, compile(gl.VERTEX_SHADER, vertex));
  gl.attachShader(program, compile(gl.FRAGMENT_SHADER, fragment));
  gl.linkProgram(program);
  if (!gl.getProgramParameter(program, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(program));
  const buffer = gl.createBuffer();
  gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
  gl.bufferData(gl.ARRAY_BUFFER, new Float32Array([-1, -1, 1, -1, -1, 1, 1, 1]), gl.STATIC_DRAW);
  const corner = gl.getAttribLocation(program, "corner");
  gl.enableVertexAttribArray(corner);
  gl.vertexAttribPointer(corner, 2, gl.FLOAT, false, 0, 0);
  valueTexture = newTexture();
  mapTexture = newTexture();
}

function newTexture() {
  const texture = gl.createTexture();
  gl.bindTexture(gl.TEXTURE_2D, texture);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
  return texture;
}

function loadColourMap(map) {
  state.colourMap = map;
  const bytes = new Uint8Array(256 * 4);
  map.steps.forEach((c, i) => bytes.set([c[0], c[1], c[2], 255], 4 * i));
  if (gl) {
    gl.bindTexture(gl.TEXTURE_2D, mapTexture);
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA8, 256, 1, 0, gl.RGBA, gl.UNSIGNED_BYTE, bytes);
  }
  drawColourBar();
}

function drawColourBar() {
  const bar = $("colour-bar");
  const context = bar.getContext("2d");
  if (state.product === "flags" || !state.colourMap) {
    context.clearRect(0, 0, bar.width, bar.height);
    return;
  }
  for (let i = 0; i < 256; ++i) {  // the highest value at the top
    const c = state.colourMap.steps[i];
    context.fillStyle = `rgb(${c[0]},${c[1]},${c[2]})`;
    context.fillRect(0, 255 - i, bar.width, 1);
  }
}

// The image of the shown product: its name in the frame.
function shownImageName() {
  if (state.product === "slices") return `slices/${state.slice}`;
  return state.product;
}

function draw() {
  const frame = state.frame;
  if (!frame || !gl || !program) return;
  const image = frame.images.get(shownImageName());
  if (!image) return;
  const canvas = $("view");
  if (canvas.width !== state.width || canvas.height !== state.height) {
    canvas.width = state.width;
    canvas.height = state.height;
  }
  gl.viewport(0, 0, state.width, state.height);
  gl.useProgram(program);
  gl.activeTexture(gl.TEXTURE0);
  gl.bindTexture(gl.TEXTURE_2D, valueTexture);
  gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
  if (image.type === "f16") {
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.R16F, state.width, state.height, 0, gl.RED, gl.HALF_FLOAT,
                  image.values);
  } else {
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.R8, state.width, state.height, 0, gl.RED,
                  gl.UNSIGNED_BYTE, image.values);
  }
  gl.activeTexture(gl.TEXTURE1);
  gl.bindTexture(gl.TEXTURE_2D, mapTexture);
  const [lo, hi] = currentScale();
  gl.uniform1i(gl.getUniformLocation(program, "values"), 0);
  gl.uniform1i(gl.getUniformLocation(program, "colourMap"), 1);
  gl.uniform1f(gl.getUniformLocation(program, "lo"), lo);
  gl.uniform1f(gl.getUniformLocation(program, "hi"), hi > lo ? hi : lo + 1e-6);
  gl.uniform1i(gl.getUniformLocation(program, "flags"), state.product === "flags" ? 1 : 0);
  const grey = state.colourMap ? state.colourMap.noValue : [128, 128, 128];
  gl.uniform3f(gl.getUniformLocation(program, "noValue"), grey[0] / 255, grey[1] / 255, grey[2] / 255);
  const colours = new Float32Array(21);
  FLAG_BITS.forEach(([, , hex], i) => colours.set(hexToRgb(hex), 3 * i));
  gl.uniform3fv(gl.getUniformLocation(program, "flagColours"), colours);
  gl.drawArrays(gl.TRIANGLE_STRIP, 0, 4);
}

function hexToRgb(hex) {
  const n = parseInt(hex.slice(1), 16);
  return [(n >> 16) / 255, ((n >> 8) & 255) / 255, (n & 255) / 255];
}

// ---------------------------------------------------------------- values and scales
function halfToFloat(h) {
  const sign = h & 0x8000 ? -1 : 1, exponent = (h >> 10) & 0x1f, fraction = h & 0x3ff;
  if (exponent === 0) return sign * Math.pow(2, -14) * (fraction / 1024);
  if (exponent === 31) return fraction ? NaN : sign * Infinity;
  return sign * Math.pow(2, exponent - 15) * (1 + fraction / 1024);
}

// The value of the shown image at sensor pixel (x, y), as a number (NaN for none).
function valueAt(x, y, name = shownImageName()) {
  const image = state.frame && state.frame.images.get(name);
  if (!image) return NaN;
  const v = image.values[y * state.width + x];
  return image.type === "f16" ? halfToFloat(v) : v;
}

function currentScale() {
  const scale = state.scales[state.product];
  if (scale) return scale;
  const automatic = autoScale();
  state.scales[state.product] = automatic;
  showScale();
  return automatic;
}

// The 1st to the 99th percentile of the shown image's finite values.
function autoScale() {
  const image = state.frame && state.frame.images.get(shownImageName());
  if (!image || image.type !== "f16") return [0, 1];
  const values = [];
  for (let i = 0; i < image.values.length; i += Math.max(1, Math.floor(image.values.length / 4096))) {
    const v = halfToFloat(image.values[i]);
    if (Number.isFinite(v)) values.push(v);
  }
  if (!values.length) return [0, 1];
  values.sort((a, b) => a - b);
  const lo = values[Math.floor(0.01 * (values.length - 1))];
  const hi = values[Math.ceil(0.99 * (values.length - 1))];
  return [lo, hi > lo ? hi : lo + 1];
}

function showScale() {
  const flags = state.product === "flags";
  $("flags-legend").hidden = !flags;
  $("colour-bar-box").style.visibility = flags ? "hidden" : "visible";
  if (flags) return;
  const [lo, hi] = state.scales[state.product] || [0, 1];
  $("scale-lo").value = +lo.toPrecision(4);
  $("scale-hi").value = +hi.toPrecision(4);
  $("bar-lo").textContent = (+lo.toPrecision(4)).toString();
  $("bar-hi").textContent = (+hi.toPrecision(4)).toString();
  $("bar-unit").textContent = UNITS[state.product];
}

// ---------------------------------------------------------------- frames
function onFrame(buffer) {
  const bytes = new Uint8Array(buffer);
  if (bytes.length < 8 || String.fromCharCode(...bytes.subarray(0, 4)) !== "TRF1") return;
  const headerLength = new DataView(buffer).getUint32(4, true);
  const header = JSON.parse(new TextDecoder().decode(bytes.subarray(8, 8 + headerLength)));
  const payload = 8 + headerLength;
  const images = new Map();
  for (const image of header.images) {
    const start = payload + image.offset;
    const values = image.type === "f16" ? new Uint16Array(buffer, start, image.length / 2)
                                        : new Uint8Array(buffer, start, image.length);
    images.set(image.name, { values, type: image.type, tofNs: image.tofNs });
  }
  const now = performance.now();
  state.arrivals.push(now);
  while (state.arrivals.length && now - state.arrivals[0] > 3000) state.arrivals.shift();
  state.missed += header.missed;
  if ($("hold").checked && state.frame) return;
  state.frame = { header, images };
  state.width = header.width;
  state.height = header.height;
  const slices = header.images.filter((i) => i.name.startsWith("slices/")).length;
  // Only what the source serves can be chosen (a Kinect v2 has no slices, a depth camera may
  // have no amplitude).
  for (const option of $("product").options) {
    option.disabled = option.value === "slices" ? slices === 0 : !images.has(option.value);
  }
  const slider = $("slice");
  if (+slider.max !== Math.max(0, slices - 1)) slider.max = Math.max(0, slices - 1);
  document.body.dataset.sequence = header.sequence;  // for tests and curious users
  draw();
  showSliceLabel();
}

function showSliceLabel() {
  const image = state.frame && state.frame.images.get(`slices/${state.slice}`);
  if (!image) { $("slice-label").textContent = ""; return; }
  const distance = 0.5 * SPEED_OF_LIGHT * image.tofNs * 1e-9;
  $("slice-label").textContent =
    `time of flight ${image.tofNs.toFixed(2)} ns = ${distance.toFixed(3)} m away`;
}

// ---------------------------------------------------------------- the gateway
function connect() {
  // The key of the URL that `transient web` printed: the gateway refuses a WebSocket without it.
  const key = new URLSearchParams(location.search).get("key") || "";
  const socket = new WebSocket(`ws://${location.host}/ws?key=${encodeURIComponent(key)}`);
  socket.binaryType = "arraybuffer";
  state.socket = socket;
  socket.onopen = () => {
    hideBanner("gateway");
    call("GetConfig").then(showConfig).catch(() => {});
  };
  socket.onmessage = (event) => {
    if (typeof event.data !== "string") { onFrame(event.data); return; }
    onText(JSON.parse(event.data));
  };
  socket.onclose = () => {
    state.socket = null;
    for (const { reject } of state.pending.values()) reject({ code: "UNAVAILABLE", message: "the gateway went away" });
    state.pending.clear();
    showBanner("The web gateway is gone; reconnecting…", "gateway");
    setTimeout(connect, 1000);
  };
}

function onText(message) {
  if (message.news === "daemon") {
    if (message.body.connected) hideBanner("daemon");
    else showBanner(`transientd is unreachable (${message.body.message}); the gateway keeps trying.`, "daemon");
    return;
  }
  if (message.news === "info") {
    state.info = message.body;
    $("source").textContent = message.body.sourceUri;
    return;
  }
  if (message.news === "state") { $("stat-state").textContent = message.body.state.toLowerCase(); return; }
  if (message.news === "stats") { showStats(message.body, message.gateway); return; }
  const waiting = state.pending.get(message.id);
  if (!waiting) return;
  if (message.progress) { if (waiting.progress) waiting.progress(message.progress); return; }
  state.pending.delete(message.id);
  if (message.ok) waiting.resolve(message.result);
  else waiting.reject(message.error);
}

// A call of transientd through the gateway: resolves with the result, rejects with
// {code, message} (the daemon's words).
function call(method, request = {}, progress = null) {
  return new Promise((resolve, reject) => {
    if (!state.socket || state.socket.readyState !== WebSocket.OPEN) {
      reject({ code: "UNAVAILABLE", message: "not connected to the gateway" });
      return;
    }
    const id = state.nextId++;
    state.pending.set(id, { resolve, reject, progress });
    state.socket.send(JSON.stringify({ id, method, request }));
  });
}

const banners = new Map();
function showBanner(text, key = "other") { banners.set(key, text); renderBanner(); }
function hideBanner(key) { banners.delete(key); renderBanner(); }
function renderBanner() {
  const banner = $("banner");
  banner.hidden = banners.size === 0;
  banner.textContent = [...banners.values()].join(" ");
}

function showStats(stats, gateway) {
  const times = state.arrivals;
  const rate = times.length > 1 ? (times.length - 1) / ((times[times.length - 1] - times[0]) / 1000) : 0;
  $("stat-rate").textContent = rate.toFixed(1);
  $("stat-state").textContent = (stats.state || "").toLowerCase();
  const latency = stats.latency || {};
  $("stat-latency").textContent = `${(latency.p50Ms || 0).toFixed(1)} / ${(latency.p99Ms || 0).toFixed(1)} ms`;
  $("stat-missed").textContent = String(state.missed);
  $("stat-dropped").textContent = gateway ? `${gateway.dropped} of ${gateway.sent + gateway.dropped}` : "—";
  const recording = stats.recording || {};
  $("stat-recording").textContent = recording.active
    ? `${recording.path}: ${recording.rawFrames} raw frames`
    : (recording.path ? `${recording.path} ended${recording.error ? ": " + recording.error : ""}` : "none");
}

// ---------------------------------------------------------------- the pixel plot
async function showPixel(x, y) {
  $("pixel-title").textContent = `(${x}, ${y})`;
  try {
    const pixel = await call("GetPixel", { x, y, bins: 256 });
    plotPixel(pixel);
  } catch (error) {
    $("pixel-returns").textContent = `${error.code}: ${error.message}`;
  }
}

function plotPixel(pixel) {
  const canvas = $("pixel-plot");
  const c = canvas.getContext("2d");
  const W = canvas.width, H = canvas.height, left = 48, right = 12, top = 28, bottom = 30;
  c.clearRect(0, 0, W, H);
  const t = pixel.timeOfFlightNs || [], density = pixel.density || [];
  const lower = pixel.lower || [], upper = pixel.upper || [];
  if (!t.length) return;
  const tMax = t[t.length - 1] + (t[1] - t[0]);
  const yMax = Math.max(...density.filter(Number.isFinite), ...upper.filter(Number.isFinite), 1e-12) * 1.05;
  const X = (ns) => left + (W - left - right) * ns / tMax;
  const Y = (v) => H - bottom - (H - top - bottom) * Math.min(v, yMax) / yMax;
  c.fillStyle = "#ddd8";
  c.beginPath();
  t.forEach((ns, i) => c.lineTo(X(ns), Y(upper[i] || 0)));
  for (let i = t.length - 1; i >= 0; --i) c.lineTo(X(t[i]), Y(lower[i] || 0));
  c.fill();
  c.strokeStyle = "#1f3b73";
  c.lineWidth = 1.5;
  c.beginPath();
  t.forEach((ns, i) => c.lineTo(X(ns), Y(density[i])));
  c.stroke();
  // Pisarenko's returns: a line at each time of flight, as high as its share of their weight.
  const returns = pixel.returns || [];
  const heaviest = Math.max(...returns.map((r) => r.weight), 1e-12);
  c.strokeStyle = "#d62728";
  for (const r of returns) {
    c.beginPath();
    c.moveTo(X(r.timeOfFlightNs), Y(0));
    c.lineTo(X(r.timeOfFlightNs), Y(yMax * Math.max(0.05, r.weight / heaviest)));
    c.stroke();
  }
  c.fillStyle = "#333";
  c.font = "11px sans-serif";
  c.textAlign = "center";
  for (let i = 0; i <= 5; ++i) {
    const ns = tMax * i / 5;
    c.fillText(`${ns.toFixed(1)}`, X(ns), H - bottom + 13);
    c.fillText(`${(0.5 * SPEED_OF_LIGHT * ns * 1e-9).toFixed(2)}`, X(ns), top - 6);
  }
  c.fillText("time of flight (ns)", (left + W - right) / 2, H - 3);
  c.fillText("range (m)", (left + W - right) / 2, 11);
  c.textAlign = "left";
  c.fillText("density", 2, top + 10);
  $("pixel-returns").textContent = returns.length
    ? "Pisarenko returns: " + returns.map((r) => `${r.rangeM.toFixed(3)} m (weight ${r.weight.toPrecision(3)})`).join(", ")
    : "no Pisarenko return";
  document.body.dataset.pixelReturns = String(returns.length);
}

// ---------------------------------------------------------------- controls
function showConfig(config) {
  for (const field of ["rangeMethod", "biasEpsilon", "threshold", "smoothingSigmaPx"]) {
    if (config[field] !== undefined) $(`config-${field}`).value = config[field];
  }
}

async function applyConfig(event) {
  event.preventDefault();
  const fields = {
    rangeMethod: $("config-rangeMethod").value,
    biasEpsilon: parseFloat($("config-biasEpsilon").value),
    threshold: parseFloat($("config-threshold").value),
    smoothingSigmaPx: parseFloat($("config-smoothingSigmaPx").value),
  };
  // One field at a time, so that a refusal lands next to its field.
  for (const [field, value] of Object.entries(fields)) {
    $(`error-${field}`).textContent = "";
    try {
      showConfig(await call("SetConfig", { [field]: value }));
    } catch (error) {
      $(`error-${field}`).textContent = error.message;
    }
  }
}

function setProduct(product) {
  state.product = product;
  $("video-controls").hidden = product !== "slices";
  showScale();
  drawColourBar();
  draw();
  showScale();
}

function tick() {
  if (state.playing) {
    const slider = $("slice");
    state.slice = (state.slice + 1) % (+slider.max + 1);
    slider.value = state.slice;
    draw();
    showSliceLabel();
  }
  setTimeout(tick, 80);
}

function setUpControls() {
  $("product").onchange = (e) => setProduct(e.target.value);
  const setScale = () => {
    state.scales[state.product] = [parseFloat($("scale-lo").value), parseFloat($("scale-hi").value)];
    showScale();
    draw();
  };
  $("scale-lo").onchange = setScale;
  $("scale-hi").onchange = setScale;
  $("scale-auto").onclick = () => { state.scales[state.product] = autoScale(); showScale(); draw(); };
  $("slice").oninput = (e) => { state.slice = +e.target.value; draw(); showSliceLabel(); };
  $("play").onclick = () => { state.playing = !state.playing; $("play").textContent = state.playing ? "pause" : "play"; };
  $("view").onclick = (e) => {
    const rect = e.target.getBoundingClientRect();
    const x = Math.floor((e.clientX - rect.left) / rect.width * state.width);
    const y = Math.floor((e.clientY - rect.top) / rect.height * state.height);
    if (x >= 0 && y >= 0 && x < state.width && y < state.height) showPixel(x, y);
  };
  $("view").onmousemove = (e) => {
    const rect = e.target.getBoundingClientRect();
    const x = Math.floor((e.clientX - rect.left) / rect.width * state.width);
    const y = Math.floor((e.clientY - rect.top) / rect.height * state.height);
    const v = valueAt(x, y);
    $("hover").textContent = `(${x}, ${y}): ${Number.isFinite(v) ? v.toPrecision(4) : "no value"} ${UNITS[state.product]}`;
  };
  $("config-form").onsubmit = applyConfig;
  $("record-form").onsubmit = async (e) => {
    e.preventDefault();
    $("record-error").textContent = "";
    try { await call("StartRecording", { path: $("record-name").value }); }
    catch (error) { $("record-error").textContent = error.message; }
  };
  $("record-stop").onclick = async () => {
    $("record-error").textContent = "";
    try { await call("StopRecording"); } catch (error) { $("record-error").textContent = error.message; }
  };
  $("calibrate-form").onsubmit = async (e) => {
    e.preventDefault();
    const bar = $("calibrate-progress");
    bar.hidden = false;
    bar.value = 0;
    $("calibrate-error").textContent = "";
    try {
      const result = await call("Calibrate", { takes: +$("calibrate-takes").value },
                                (p) => { bar.max = p.total; bar.value = p.done; });
      $("calibrate-result").textContent =
        `${result.takesAveraged} takes, ${result.usablePixels} of ${result.pixels} pixels usable, ${result.applied ? "applied" : "not applied"}`;
    } catch (error) {
      $("calibrate-error").textContent = error.message;
    }
    bar.hidden = true;
  };
  const legend = $("flags-legend");
  for (const [bit, name, colour] of FLAG_BITS) {
    const item = document.createElement("li");
    item.innerHTML = `<span style="background:${colour}"></span>${bit} ${name}`;
    legend.appendChild(item);
  }
}

setUpGpu();
setUpControls();
setProduct("range");
fetch("colormap.json").then((r) => r.json()).then((map) => { loadColourMap(map); draw(); });
connect();
tick();
