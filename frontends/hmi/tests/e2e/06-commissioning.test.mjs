// Commissioning from DIAGNOSTICS: the table drive's delay measured while the key is held (the
// procedure of `hob commission delay`, run by the HMI server with the held key as its
// enable), through the page in Chromium against hob-sim. Letting go mid-way stops the
// table and writes nothing; held to the end, the found delay, the fit and the diff of the
// machine file show; this panel (a setter's, through the gateway) may not WRITE: the key is
// dark, the level says whose work it is, and the machine file stays as it was. A builder's
// panel on the machine PC writes it: the record renewed, the old file kept beside it.
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
