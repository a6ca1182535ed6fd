// The viewer page of `transient web` in Debian's Chromium, headless, driven by Playwright
// (playwright-core from the lock file beside this file; no browser download), against a real
// transientd on the simulator and the real gateway (docs/web.md "Tests").
//
//   TRANSIENTD=build/service/transientd TRANSIENT=build/tools/transient/transient \
//     WEB_TEST_OUT=out/web node --test tests/web/viewer_test.mjs
//
// WEB_TEST_OUT gets the screenshots (docs/images/web_viewer*.png are copies of them) and
// rate.json, the frame delivery measured here.
import { test, before, after } from "node:test";
import assert from "node:assert/strict";
import { spawn } from "node:child_process";
import { request as httpRequest } from "node:http";
import { connect as tcpConnect } from "node:net";
import { mkdtempSync, mkdirSync, readFileSync, existsSync, writeFileSync, rmSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";

let chromium;
try {
  ({ chromium } = await import("playwright-core"));
} catch (error) {
  throw new Error(`playwright-core is not installed in tests/web (make deps runs npm ci there): ${error.message}`);
}

const TRANSIENTD = process.env.TRANSIENTD;
const TRANSIENT = process.env.TRANSIENT;
const CHROMIUM = process.env.CHROMIUM || "/usr/bin/chromium";
const OUT = process.env.WEB_TEST_OUT || mkdtempSync(join(tmpdir(), "transient-web-out-"));
const WIDTH = 64, HEIGHT = 48;
// The simulated camera at its own pace (14 raw frames of 5.7 ms, about 12.5 frames/s) on the
// corner scene: a wall corner, whose range spans the colour scale; without noise, so that every
// frame is the same (the pixel test below compares two).
const SOURCE = `sim:corner?width=${WIDTH}&height=${HEIGHT}&noise=none`;

const work = mkdtempSync(join(tmpdir(), "transient-web-"));
let daemon, gateway, browser, page, daemonPort, pageUrl;

function sleep(ms) { return new Promise((resolve) => setTimeout(resolve, ms)); }

async function waitFor(what, condition, timeoutMs = 20000) {
  const until = Date.now() + timeoutMs;
  for (;;) {
    const value = await condition();
    if (value) return value;
    if (Date.now() > until) throw new Error(`timed out waiting for ${what}`);
    await sleep(50);
  }
}

function startProcess(name, command, args, env = process.env) {
  const log = [];
  const child = spawn(command, args, { stdio: ["ignore", "pipe", "pipe"], env });
  child.stdout.on("data", (d) => log.push(d.toString()));
  child.stderr.on("data", (d) => log.push(d.toString()));
  child.log = () => `${name}:\n${log.join("")}`;
  return child;
}

async function readPort(file, child) {
  return waitFor(`${file}`, () => {
    if (child.exitCode !== null) throw new Error(`exited with ${child.exitCode}\n${child.log()}`);
    return existsSync(file) && readFileSync(file, "utf8").trim() ? +readFileSync(file, "utf8") : 0;
  }, 60000);
}

async function startDaemon(listen) {
  const portFile = join(work, `daemon-port-${Date.now()}`);
  daemon = startProcess("transientd", TRANSIENTD, [
    "--source", SOURCE, "--listen", listen, "--port-file", portFile,
    "--data-dir", join(work, "data")]);
  return readPort(portFile, daemon);
}

function stop(child) {
  return new Promise((resolve) => {
    if (!child || child.exitCode !== null) { resolve(child ? child.exitCode : 0); return; }
    child.once("exit", (code) => resolve(code));
    child.kill("SIGTERM");
  });
}

// RGB of the view canvas at sensor pixel (x, y), and of the colour bar's steps.
async function viewPixel(x, y) {
  return page.evaluate(([x, y]) => {
    const view = document.getElementById("view");
    const copy = document.createElement("canvas");
    copy.width = view.width;
    copy.height = view.height;
    const context = copy.getContext("2d");
    context.drawImage(view, 0, 0);
    return Array.from(context.getImageData(x, y, 1, 1).data.slice(0, 3));
  }, [x, y]);
}

async function barColour(step) {
  return page.evaluate((step) => {
    const bar = document.getElementById("colour-bar");
    return Array.from(bar.getContext("2d").getImageData(2, 255 - step, 1, 1).data.slice(0, 3));
  }, step);
}

// A digest of the view: enough to tell two pictures apart.
async function viewDigest() {
  return page.evaluate(() => {
    const view = document.getElementById("view");
    const copy = document.createElement("canvas");
    copy.width = view.width;
    copy.height = view.height;
    const context = copy.getContext("2d");
    context.drawImage(view, 0, 0);
    const data = context.getImageData(0, 0, copy.width, copy.height).data;
    let hash = 0;
    for (let i = 0; i < data.length; ++i) hash = (hash * 31 + data[i]) >>> 0;
    return hash;
  });
}

const sequence = () => page.evaluate(() => +(document.body.dataset.sequence || -1));

// Counts the frames reaching the page from now on in window.framesReceived.
async function countFrames() {
  await page.evaluate(() => {
    window.framesReceived = 0;
    if (window.countingSocket === state.socket) return;
    window.countingSocket = state.socket;
    state.socket.addEventListener("message", (e) => {
      if (typeof e.data !== "string") ++window.framesReceived;
    });
  });
}

before(async () => {
  assert.ok(TRANSIENTD && TRANSIENT, "set TRANSIENTD and TRANSIENT to the built programs");
  mkdirSync(join(work, "data"), { recursive: true });
  mkdirSync(OUT, { recursive: true });
  daemonPort = await startDaemon("127.0.0.1:0");
  const webPortFile = join(work, "web-port"), urlFile = join(work, "web-url");
  gateway = startProcess("transient web", TRANSIENT, [
    "web", "--connect", `127.0.0.1:${daemonPort}`, "--listen", "127.0.0.1:0",
    "--port-file", webPortFile, "--url-file", urlFile, "--bins", "32"],
    // Under AddressSanitizer (make test), freed memory waits in a quarantine of up to 256 MB
    // before it is reused: without it, the gateway's resident memory is its own again.
    { ...process.env, ASAN_OPTIONS: ["quarantine_size_mb=0", process.env.ASAN_OPTIONS]
                                    .filter(Boolean).join(":") });
  await readPort(webPortFile, gateway);
  pageUrl = readFileSync(urlFile, "utf8").trim();  // with the page's key
  assert.match(pageUrl, /^http:\/\/127\.0\.0\.1:[0-9]+\/\?key=[0-9a-f]{32}$/);
  browser = await chromium.launch({
    executablePath: CHROMIUM,
    // WebGL2 without a GPU: SwiftShader, which Chromium enables headless only when asked.
    args: ["--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
           "--ignore-gpu-blocklist"],
  });
  page = await browser.newPage({ viewport: { width: 1400, height: 820 } });
  page.on("pageerror", (error) => console.log(`page error: ${error.message}`));
  await page.goto(pageUrl);
});

after(async () => {
  if (browser) await browser.close();
  const gatewayExit = await stop(gateway);
  await stop(daemon);
  rmSync(work, { recursive: true, force: true });  // the port files and the daemon's data
  assert.equal(gatewayExit, 0, `transient web did not exit 0 on SIGTERM\n${gateway.log()}`);
});

test("the page loads and shows the range image", async () => {
  await waitFor("a frame on the page", async () => (await sequence()) >= 0);
  const size = await page.evaluate(() => [document.getElementById("view").width,
                                          document.getElementById("view").height]);
  assert.deepEqual(size, [WIDTH, HEIGHT]);
  const corners = [await viewPixel(2, 2), await viewPixel(WIDTH / 2, HEIGHT / 2)];
  assert.notDeepEqual(corners[0], [0, 0, 0], "the view is not drawn");
  const source = await page.textContent("#source");
  assert.match(source, /sim:corner/);
});

test("a pixel's colour is the colour bar's colour for its range", async () => {
  const [x, y] = [WIDTH / 2, HEIGHT / 2];
  await page.check("#hold");
  // The range of the pixel in the frame shown (as it arrived, a half float), which must be the
  // daemon's for that pixel (GetPixel of its latest frame, through the page's call: by the
  // reference kernel, within the optimized one's 0.1 mm; the page lags the daemon by a frame or
  // more, and the noise-free camera's frames are the same), and the page's scale. A half
  // float's step is 2^-10 of its power of two: within 0.1 %.
  const shownRange = await page.evaluate(([x, y]) => valueAt(x, y), [x, y]);
  const pixel = await page.evaluate(([x, y]) => call("GetPixel", { x, y }), [x, y]);
  assert.ok(Math.abs(shownRange - pixel.rangeM) <= 1e-3 * Math.abs(pixel.rangeM),
            `the page shows ${shownRange} m, the daemon's latest frame has ${pixel.rangeM} m`);
  const [lo, hi] = await page.evaluate(() => [+document.getElementById("scale-lo").value,
                                              +document.getElementById("scale-hi").value]);
  const step = Math.round(Math.min(1, Math.max(0, (shownRange - lo) / (hi - lo))) * 255);
  const shown = await viewPixel(x, y);
  // The scale's ends are shown rounded to 4 digits: a step either way.
  let nearest = Infinity;
  for (let s = Math.max(0, step - 1); s <= Math.min(255, step + 1); ++s) {
    const c = await barColour(s);
    nearest = Math.min(nearest, Math.max(...c.map((v, i) => Math.abs(v - shown[i]))));
  }
  assert.ok(nearest <= 2, `pixel (${x}, ${y}) at ${shownRange} m is ${shown}, the bar's step ` +
            `${step} of [${lo}, ${hi}] m is ${await barColour(step)}`);
  await page.uncheck("#hold");
});

test("moving the slider changes the slice", async () => {
  await page.selectOption("#product", "slices");
  await page.check("#hold");
  const slider = page.locator("#slice");
  await slider.fill("4");
  const label4 = await page.textContent("#slice-label");
  const digest4 = await viewDigest();
  await slider.fill("12");
  const label12 = await page.textContent("#slice-label");
  const digest12 = await viewDigest();
  assert.match(label4, /time of flight [0-9.]+ ns = [0-9.]+ m away/);
  assert.notEqual(label4, label12);
  assert.notEqual(digest4, digest12, "the picture did not change with the slice");
  await page.uncheck("#hold");
  await page.selectOption("#product", "range");
});

test("clicking a pixel draws its transient with the returns", async () => {
  const box = await page.locator("#view").boundingBox();
  await page.mouse.click(box.x + box.width * (20.5 / WIDTH), box.y + box.height * (30.5 / HEIGHT));
  await waitFor("the pixel plot", async () =>
    page.evaluate(() => document.body.dataset.pixelReturns !== undefined));
  assert.match(await page.textContent("#pixel-title"), /\(20, 30\)/);
  assert.match(await page.textContent("#pixel-returns"), /Pisarenko returns: [0-9.]+ m \(weight/);
  await page.screenshot({ path: join(OUT, "web_viewer.png") });
});

test("a bad setting shows the daemon's refusal next to its field", async () => {
  await page.fill("#config-threshold", "5");
  await page.click("#config-form button[type=submit]");
  const message = await waitFor("the refusal", async () => page.textContent("#error-threshold"));
  assert.match(message, /threshold/);
  assert.equal(await page.textContent("#error-smoothingSigmaPx"), "");
});

// Status and body of a raw HTTP request to the gateway, with the headers given.
function raw(method, path, headers) {
  const { port } = new URL(pageUrl);
  return new Promise((resolve, reject) => {
    const r = httpRequest({ host: "127.0.0.1", port, method, path, headers }, (response) => {
      let body = "";
      response.on("data", (d) => { body += d; });
      response.on("end", () => resolve([response.statusCode, body]));
    });
    r.on("upgrade", (response, socket) => { socket.destroy(); resolve([response.statusCode, ""]); });
    r.on("error", reject);
    r.end();
  });
}

test("the gateway refuses other hosts, other origins, other methods and unknown files", async () => {
  const host = new URL(pageUrl).host;
  assert.equal((await raw("GET", "/", { Host: host }))[0], 200);
  // DNS rebinding: a page of another name that resolves to this machine.
  const [status, body] = await raw("GET", "/", { Host: "attacker.example:80" });
  assert.equal(status, 403);
  assert.match(body, /only requests for its own address/);
  assert.equal((await raw("POST", "/", { Host: host }))[0], 405);
  assert.equal((await raw("GET", "/../../etc/passwd", { Host: host }))[0], 404);
  assert.equal((await raw("GET", "/.hidden", { Host: host }))[0], 404);
  const upgrade = { Host: host, Connection: "Upgrade", Upgrade: "websocket",
                    "Sec-WebSocket-Version": "13", "Sec-WebSocket-Key": "dGhlIHNhbXBsZSBub25jZQ==" };
  const ours = { ...upgrade, Origin: `http://${host}` };
  const key = new URL(pageUrl).searchParams.get("key");
  assert.equal((await raw("GET", `/ws?key=${key}`, ours))[0], 101);
  // Another site open in the same browser may not drive the daemon through the gateway.
  assert.equal((await raw("GET", `/ws?key=${key}`, { ...upgrade, Origin: "http://attacker.example" }))[0], 403);
  assert.equal((await raw("GET", `/ws?key=${key}`, upgrade))[0], 403);  // no Origin: not a page of ours
  assert.equal((await raw("GET", `/other?key=${key}`, ours))[0], 403);
  // Nor may another user of this machine, who can reach the port but has not got the URL.
  const [refused, why] = await raw("GET", "/ws", ours);
  assert.equal(refused, 403);
  assert.match(why, /key is missing or wrong/);
  assert.equal((await raw("GET", `/ws?key=${key.replace(/.$/, (c) => (c === "0" ? "1" : "0"))}`, ours))[0], 403);
});

test("a request the gateway cannot read is refused and the page goes on", async () => {
  const replies = await page.evaluate(async () => {
    const got = [];
    const socket = state.socket;
    const listen = (e) => { if (typeof e.data === "string" && JSON.parse(e.data).ok === false) got.push(JSON.parse(e.data)); };
    socket.addEventListener("message", listen);
    socket.send("this is not JSON");
    socket.send(JSON.stringify({ id: 900001, method: "Shutdown" }));
    socket.send(JSON.stringify({ id: 900002, method: "GetPixel", request: { x: 100000, y: 0 } }));
    for (let i = 0; i < 100 && got.length < 3; ++i) await new Promise((r) => setTimeout(r, 50));
    socket.removeEventListener("message", listen);
    return got;
  });
  assert.equal(replies.length, 3, JSON.stringify(replies));
  const byId = Object.fromEntries(replies.map((r) => [r.id, r.error]));
  assert.equal(byId[0].code, "INVALID_ARGUMENT");
  assert.match(byId[900001].message, /'Shutdown' is not one of/);
  assert.equal(byId[900002].code, "INVALID_ARGUMENT");  // the daemon's refusal, as it said it
  const before = await sequence();
  await waitFor("frames after the bad requests", async () => (await sequence()) > before);
});

test("frame delivery keeps up with the camera", async () => {
  // Frames that reach the page in 5 s against those the daemon published meanwhile.
  const published = async () => (await page.evaluate(() => call("GetStats"))).framesPublished;
  const count = () => page.evaluate(() => window.framesReceived);
  await countFrames();
  const p0 = Number(await published());
  await sleep(5000);
  const received = await count();
  const p1 = Number(await published());
  const rate = { seconds: 5, published: p1 - p0, received, ratio: received / Math.max(1, p1 - p0) };
  writeFileSync(join(OUT, "rate.json"), JSON.stringify(rate, null, 1));
  console.log(`frame delivery: ${received} frames received by the page, ${p1 - p0} published by ` +
              `the daemon in 5 s (${(received / 5).toFixed(1)} frames/s)`);
  assert.ok(rate.ratio >= 0.9, JSON.stringify(rate));
});

// Resident memory of a process in MiB, from /proc.
function residentMiB(pid) {
  const status = readFileSync(`/proc/${pid}/status`, "utf8");
  return +status.match(/VmRSS:\s+(\d+)/)[1] / 1024;
}

test("a page that reads nothing costs the gateway no memory and the others no frames", async () => {
  // A WebSocket client of the gateway's own origin that completes the handshake and then never
  // reads: its frames must be dropped at the gateway, not queued.
  const { port, host } = new URL(pageUrl);
  const stuck = tcpConnect({ host: "127.0.0.1", port: +port });
  await new Promise((resolve) => stuck.once("connect", resolve));
  const key = new URL(pageUrl).searchParams.get("key");
  stuck.write(`GET /ws?key=${key} HTTP/1.1\r\nHost: ${host}\r\nOrigin: http://${host}\r\n` +
              "Connection: Upgrade\r\nUpgrade: websocket\r\nSec-WebSocket-Version: 13\r\n" +
              "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n\r\n");
  const answer = await new Promise((resolve) => stuck.once("data", (d) => resolve(d.toString())));
  assert.match(answer, /^HTTP\/1.1 101/);
  stuck.pause();  // and from now on nothing is read
  const before = residentMiB(gateway.pid);
  await countFrames();
  const published = async () => Number((await page.evaluate(() => call("GetStats"))).framesPublished);
  const p0 = await published();
  await sleep(10000);
  const received = await page.evaluate(() => window.framesReceived);
  const p1 = await published();
  const after = residentMiB(gateway.pid);
  stuck.destroy();
  // Queued, 10 s of this stream (about 200 KB a frame at 13 frames/s) would be 26 MB.
  console.log(`a stuck page: the gateway's resident memory ${before.toFixed(1)} -> ` +
              `${after.toFixed(1)} MiB in 10 s; the live page received ${received} of ${p1 - p0}`);
  // (Measured: about 1 MiB in Release, 4 under the sanitizers, where allocations are larger.)
  assert.ok(after - before < 12, `the gateway grew from ${before} to ${after} MiB`);
  assert.ok(received >= 0.9 * (p1 - p0), `the live page received ${received} of ${p1 - p0}`);
});

test("the page recovers after the daemon restarts", async () => {
  assert.equal(await stop(daemon), 0);
  await waitFor("the banner", async () =>
    page.evaluate(() => !document.getElementById("banner").hidden &&
                        /unreachable/.test(document.getElementById("banner").textContent)));
  await page.screenshot({ path: join(OUT, "web_viewer_lost.png") });
  const before = await sequence();
  await startDaemon(`127.0.0.1:${daemonPort}`);
  await waitFor("the banner to go", async () =>
    page.evaluate(() => document.getElementById("banner").hidden), 30000);
  // The restarted daemon counts its frames from 0 again: a new frame shows as a new sequence.
  await waitFor("frames again", async () => (await sequence()) !== before, 30000);
});
