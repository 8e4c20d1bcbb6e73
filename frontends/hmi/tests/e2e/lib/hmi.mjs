// The browser tests' harness: starts hob-hmi beside the loop that bench/system-tests/tests/hmi.rs
// started (hob-sim, hob-rt, hob-logger, hob-watchdog on HOB_INSTANCE), drives Debian's
// Chromium with playwright-core (a browser download does not work on these machines), and
// reads the loop's truth with `hob status --json`, never from the page.
import { spawn, execFileSync } from "node:child_process";
import { mkdtempSync, mkdirSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { chromium } from "playwright-core";

export function need(name) {
  const v = process.env[name];
  if (!v) throw new Error(`${name} is not set: run the browser tests through bench/system-tests/tests/hmi.rs (ci/test)`);
  return v;
}

const BIN = () => need("HOB_BIN");

/** Starts hob-hmi; resolves with {proc, url, port} once it says where it serves. With
 *  `builder`: a builder's panel on the bus itself (the machine PC's own user, `--level
 *  builder`), not the deployed panel through the gateway. */
export function startHmi(port = 0, { builder = false } = {}) {
  const args = ["--machine", need("HOB_MACHINE"), "--library", need("HOB_LIBRARY"), "--log-dir", need("HOB_LOG_DIR"),
    "--bind", `127.0.0.1:${port}`, "--vendor", need("HOB_VENDOR"), ...(builder ? ["--level", "builder"] : []),
    // The gear checker's folder of the COMPENSATE screen (its `hob` is the one beside hob-hmi).
    ...(process.env.HOB_MEASUREMENTS_DIR ? ["--measurements-dir", process.env.HOB_MEASUREMENTS_DIR] : [])];
  // As deployed: another user than the bus's, through hob-gateway (HOB_HMI_USER uid:gid,
  // HOB_HMI_GATEWAY its socket; bench/system-tests/tests/hmi.rs sets both).
  const user = builder ? undefined : process.env.HOB_HMI_USER;
  const [exe, argv, env] = user
    ? ["setpriv", ["--reuid", user.split(":")[0], "--regid", user.split(":")[1], "--clear-groups", "--",
        join(BIN(), "hob-hmi"), ...args], { ...process.env, HOB_GATEWAY: need("HOB_HMI_GATEWAY") }]
    : [join(BIN(), "hob-hmi"), args, process.env];
  const proc = spawn(exe, argv, { env, stdio: ["ignore", "pipe", "pipe"] });
  let err = "";
  proc.stderr.on("data", (d) => { err += d; });
  return new Promise((resolve, reject) => {
    let out = "";
    const t = setTimeout(() => reject(new Error(`hob-hmi did not start in 20 s: ${out} ${err}`)), 20000);
    proc.stdout.on("data", (d) => {
      out += d;
      const m = out.match(/serving the panel at (http:\/\/[\d.]+:(\d+)\/)/);
      if (m) { clearTimeout(t); resolve({ proc, url: m[1], port: Number(m[2]) }); }
    });
    proc.on("exit", (code) => { clearTimeout(t); reject(new Error(`hob-hmi exited ${code}: ${err}`)); });
  });
}

/** The loop's state as `hob status --json` reads it (the truth the page is checked against). */
export function status() {
  return JSON.parse(execFileSync(join(BIN(), "hob"), ["status", "--json"], { env: process.env, encoding: "utf8", timeout: 20000 }));
}

export function hob(...args) {
  return execFileSync(join(BIN(), "hob"), args, { env: process.env, encoding: "utf8", timeout: 60000 });
}

export async function waitFor(what, f, timeoutMs = 60000, everyMs = 200) {
  const end = Date.now() + timeoutMs;
  let last;
  for (;;) {
    try {
      const v = await f();
      if (v) return v;
    } catch (e) { last = e; }
    if (Date.now() > end) throw new Error(`timed out after ${timeoutMs} ms waiting for ${what}${last ? `: ${last.message}` : ""}`);
    await new Promise((r) => setTimeout(r, everyMs));
  }
}

export const CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-background-networking",
  "--disable-component-update", "--disable-sync", "--disable-quic"];

/** Chromium at the panel's size with touch (`extraArgs`: more command-line flags). */
export async function browser(extraArgs = []) {
  const profile = mkdtempSync(join(tmpdir(), "hob-hmi-chromium-"));
  const ctx = await chromium.launchPersistentContext(profile, {
    executablePath: "/usr/bin/chromium", args: [...CHROMIUM_ARGS, ...extraArgs], headless: true,
    viewport: { width: 1280, height: 800 }, hasTouch: true,
  });
  return ctx;
}

/** A screenshot into HOB_HMI_SHOTS (the tests' artifacts, or docs/hmi when refreshing them). */
export async function shot(page, name) {
  const dir = process.env.HOB_HMI_SHOTS;
  if (!dir) return;
  mkdirSync(dir, { recursive: true });
  await page.screenshot({ path: join(dir, `${name}.png`) });
}

/** Touch down on an element, hold for ms, lift: real touch events through CDP. */
export async function touchHold(page, selector, ms) {
  await page.locator(selector).scrollIntoViewIfNeeded();
  const box = await page.locator(selector).boundingBox();
  if (!box) throw new Error(`${selector}: not on screen`);
  const cdp = await page.context().newCDPSession(page);
  const p = { x: box.x + box.width / 2, y: box.y + box.height / 2 };
  await cdp.send("Input.dispatchTouchEvent", { type: "touchStart", touchPoints: [p] });
  const t0 = Date.now();
  if (ms > 0) await new Promise((r) => setTimeout(r, ms));
  return {
    cdp,
    lift: async () => { await cdp.send("Input.dispatchTouchEvent", { type: "touchEnd", touchPoints: [] }); return Date.now() - t0; },
  };
}
