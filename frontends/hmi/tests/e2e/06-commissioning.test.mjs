// Commissioning from DIAGNOSTICS: the table drive's delay measured while the key is held (the
// procedure of `hob commission delay`, run by the HMI server with the held key as its
// enable), through the page in Chromium against hob-sim. Letting go mid-way stops the
// table and writes nothing; held to the end, the found delay, the fit and the diff of the
// machine file show; this panel (a setter's, through the gateway) may not WRITE: the key is
// dark, the level says whose work it is, and the machine file stays as it was. A builder's
// panel on the machine PC writes it: the record renewed, the old file kept beside it. The
// spindle encoder's key (the procedure of `hob commission encoder`) on a builder's panel:
// held, the loop holds the hob spindle at the first speed and it turns; let go, the spindle
// stops, the card says the enable was let go and offers nothing to WRITE, the file as it was.
// The table backlash's key is 02-table-backlash.test.mjs's: it measures before the cut
// turns the table beyond the gauge's stroke; the table response's is 02b-table-response's,
// run after it (its creep would take the table beyond the gauge) and before the cut.
import { test, after } from "node:test";
import assert from "node:assert/strict";
import { readFileSync, readdirSync } from "node:fs";
import { dirname, join } from "node:path";
import { startHmi, browser, status, waitFor, shot, touchHold, need } from "./lib/hmi.mjs";

const hmi = await startHmi();
const ctx = await browser();
const page = await ctx.newPage();
after(async () => { await ctx.close(); hmi.proc.kill("SIGTERM"); });

const machine = need("HOB_MACHINE");
const before = readFileSync(machine, "utf8");
const state = () => page.locator('[data-testid="commission-state"]').getAttribute("data-state");
const text = (sel) => page.locator(sel).first().innerText();

async function measure(p) {
  const hold = await touchHold(p, '[data-testid="commission-hold"]', 0);
  const st = () => p.locator('[data-testid="commission-state"]').getAttribute("data-state");
  await waitFor("the measurement under way", async () => (await st()) === "running", 5000, 50);
  await waitFor("the proposal", async () => ["proposal", "stopped", "refused"].includes(await st()), 30000, 100);
  await hold.lift();
  assert.equal(await st(), "proposal", await p.locator('[data-testid="commission-state"]').innerText());
}

async function atRest() {
  const a = status().table_deg;
  await new Promise((r) => setTimeout(r, 400));
  const b = status().table_deg;
  assert.ok(Math.abs(a - b) < 1e-3, `the table moves: ${a} then ${b} deg`);
  return b;
}

test("letting go of the key mid-way stops the table and writes nothing", async () => {
  await page.goto(`${hmi.url}#diagnostics`);
  await page.locator('[data-testid="commissioning"]').waitFor({ timeout: 20000 });
  assert.equal(status().state, "idle", "the machine is not idle before the test");
  const b0 = status().table_deg;
  const hold = await touchHold(page, '[data-testid="commission-hold"]', 1500);
  const moving = status();
  assert.equal(moving.state, "jog", `state while held: ${moving.state}`);
  await hold.lift();
  await waitFor("the measurement stopped", async () => (await state()) === "stopped", 5000, 50);
  assert.match(await text('[data-testid="commission-state"]'), /enable was let go/);
  await waitFor("the table at rest", () => status().state === "idle", 3000, 50);
  const b1 = await atRest();
  console.log(`let go after 1.5 s: the table stood at ${b1.toFixed(3)} deg (from ${b0.toFixed(3)})`);
  assert.equal(readFileSync(machine, "utf8"), before, "the machine file changed");
});

test("held to the end: the found delay, the fit and the diff; WRITE is a builder's work", async () => {
  await measure(page);
  const found = Number((await text('[data-testid="commission-state"]')).match(/found ([\d.]+) us/)[1]);
  // hob-sim's drives follow with the delay the machine file says (config/plant.toml).
  const told = Number(before.match(/^drive_delay_us = (\d+)/m)[1]);
  assert.ok(Math.abs(found - told) <= 20, `found ${found} us, the simulated drives' delay is ${told} us`);
  assert.match(await text('[data-testid="commission-report"]'), /steady jog/);
  // The record is renewed (its time at least; the file's other lines as they were).
  assert.match(await text('[data-testid="commission-diff"]'), /\+ *\d+ +utc = /);
  assert.equal(await page.locator('[data-testid="commission-write"]').isDisabled(), true, "WRITE is offered to a setter");
  assert.match(await text('[data-testid="commission-level"]'), /builder/);
  await page.locator('[data-testid="commissioning"]').scrollIntoViewIfNeeded();
  await shot(page, "diagnostics-commissioning");
  await atRest();
  assert.equal(readFileSync(machine, "utf8"), before, "the machine file changed");
  console.log(`found ${found} us for the simulated drives' ${told} us`);
});

test("a builder's panel writes the proposal: the record renewed, the old file kept", async () => {
  const builder = await startHmi(0, { builder: true });
  const p = await ctx.newPage();
  try {
    await p.goto(`${builder.url}#diagnostics`);
    await p.locator('[data-testid="commissioning"]').waitFor({ timeout: 20000 });
    assert.equal(await p.locator('[data-testid="commission-level"]').count(), 0, "the builder is told WRITE is not theirs");
    await measure(p);
    await p.locator('[data-testid="commission-write"]').tap();
    await waitFor("written", async () => (await p.locator('[data-testid="commission-state"]').getAttribute("data-state")) === "written", 10000, 100);
    const said = await p.locator('[data-testid="commission-state"]').innerText();
    assert.match(said, /restart hob-rt/);
    const after = readFileSync(machine, "utf8");
    assert.notEqual(after, before, "the machine file is unchanged");
    const kept = readdirSync(dirname(machine)).filter((f) => f.startsWith("machine.toml.") && f.endsWith(".bak"));
    assert.equal(kept.length, 1, `kept: ${kept}`);
    assert.equal(readFileSync(join(dirname(machine), kept[0]), "utf8"), before, "the kept file is not the old one");
    const utc = (t) => t.match(/^utc = (\S+)/m)[1];
    assert.notEqual(utc(after), utc(before), "the record was not renewed");
    await shot(p, "diagnostics-commissioning-written");
    console.log(said);
  } finally {
    await p.close();
    builder.proc.kill("SIGTERM");
  }
});

test("the spindle encoder's key: held, the spindle turns at its first speed; let go, it stops and nothing is written", async () => {
  const builder = await startHmi(0, { builder: true });
  const p = await ctx.newPage();
  try {
    await p.goto(`${builder.url}#diagnostics`);
    await p.locator('[data-testid="commission-encoder-hold"]').waitFor({ timeout: 20000 });
    const warning = await p.locator('[data-testid="commission-encoder-warning"]').innerText();
    assert.match(warning, /turns at up to \d+ rpm for about \d+ min while the key is held: the hob must be clear of the work/);
    assert.equal(status().state, "idle", "the machine is not idle before the test");
    assert.ok(Math.abs(status().spindle_rpm) < 1, `the spindle turns before the test: ${status().spindle_rpm} rpm`);
    const file = readFileSync(machine, "utf8");
    const st = p.locator('[data-testid="commission-encoder-state"]');
    const t0 = Date.now();
    const hold = await touchHold(p, '[data-testid="commission-encoder-hold"]', 0);
    await waitFor("the spindle held at its first speed", async () => /holding the spindle at \d+ rpm/.test(await st.innerText()), 10000, 50);
    const first = Number((await st.innerText()).match(/holding the spindle at (\d+) rpm/)[1]);
    assert.equal(await st.getAttribute("data-state"), "running");
    // The loop's truth, not the page's: the spindle turns towards the speed held.
    const turning = await waitFor("the spindle turning", () => { const s = status(); return Math.abs(s.spindle_rpm) > 0.5 * first ? s : null; }, 15000, 200);
    await p.locator('[data-testid="commissioning"]').scrollIntoViewIfNeeded();
    await shot(p, "diagnostics-commissioning-encoder");
    const held = await hold.lift();
    await waitFor("the measurement stopped", async () => (await st.getAttribute("data-state")) === "stopped", 5000, 50);
    assert.match(await st.innerText(), /the enable was let go/);
    await waitFor("the spindle at rest", () => Math.abs(status().spindle_rpm) < 1, 15000, 200);
    assert.equal(await p.locator('[data-testid="commission-write"]').isDisabled(), true, "WRITE is offered after a stop");
    assert.equal(await p.locator('[data-testid="commission-report"]').count(), 0, "a proposal shows after a stop");
    assert.equal(readFileSync(machine, "utf8"), file, "the machine file changed");
    await waitFor("the machine idle", () => status().state === "idle", 5000, 100);
    console.log(`encoder: held ${held} ms; the spindle at ${turning.spindle_rpm.toFixed(1)} rpm (state ${turning.state}) for the first speed ${first} rpm; stopped ${((Date.now() - t0) / 1000).toFixed(1)} s after the press`);
  } finally {
    await p.close();
    builder.proc.kill("SIGTERM");
  }
});
