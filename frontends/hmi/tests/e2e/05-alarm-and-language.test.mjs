// An alarm an operator can act on, in the operator's language: a drive fault injected into
// the simulated machine (hob-sim's control, HOB_SIM_CONTROL) shows on the banner with the
// drive by name, its EMCY code and meaning and what the machine did; the banner leaves the
// navigation in view; DIAGNOSTICS has the drive's last EMCY. The language key turns the
// panel German: the loop's words (the alarm, a refusal) come from lang/de.po as well as
// the page's labels. Repaired and RESET, the alarm clears.
import { test, after } from "node:test";
import assert from "node:assert/strict";
import { appendFileSync } from "node:fs";
import { startHmi, browser, status, waitFor, shot, need } from "./lib/hmi.mjs";

const hmi = await startHmi();
const ctx = await browser();
const page = await ctx.newPage();
after(async () => { await ctx.close(); hmi.proc.kill("SIGTERM"); });

const sim = (line) => appendFileSync(need("HOB_SIM_CONTROL"), `${line}\n`);
const text = (sel) => page.locator(sel).first().innerText();

test("a drive fault: the banner names the drive, its EMCY and what the machine did; DIAGNOSTICS has the drive's last EMCY", async () => {
  await page.goto(`${hmi.url}#automatic`);
  await page.waitForSelector('[data-testid="age"]', { timeout: 20000 });
  assert.equal(status().alarm, "", "an alarm before the test");
  sim("drive-fault y");
  await waitFor("the loop's alarm (hob status)", () => status().alarm !== "", 20000, 200);
  await page.locator('[data-testid="alarm"]').waitFor({ timeout: 5000 });
  assert.match(await text('[data-testid="alarm"]'), /drive fault Y/);
  await waitFor("the drive's report on the alarm", async () => (await page.locator('[data-testid="alarm-drive-reported"]').count()) > 0, 10000);
  assert.equal(await text('[data-testid="alarm-drive-reported"]'), "drive Y reported EMCY 0x2310 continuous over-current");
  // What happened only (the machine stood idle), not the cases that did not.
  const banner = await text('[data-testid="alarm"]');
  assert.match(banner, /no cycle ran/);
  assert.doesNotMatch(banner, /in the cut|outside a cycle/);
  // The banner scrolls inside its band; the navigation stays on the screen.
  const bar = await page.locator('[data-testid="alarms-bar"]').boundingBox();
  assert.ok(bar.height <= 134, `the alarms bar is ${bar.height} px high`);
  const nav = await page.locator('button[data-screen="diagnostics"]').boundingBox();
  assert.ok(nav && nav.y >= 0 && nav.y + nav.height <= 800, `DIAGNOSTICS is off the screen: ${JSON.stringify(nav)}`);
  await shot(page, "alarm-drive-fault");
  await page.locator('button[data-screen="diagnostics"]').tap();
  await waitFor("drive Y's last EMCY on DIAGNOSTICS", async () => /0x2310/.test(await text('[data-testid="emcy-Y"]')), 10000);
  assert.match(await text('[data-testid="emcy-Y"]'), /continuous over-current/);
  await shot(page, "diagnostics-emcy");
});

test("the language key turns the panel German: labels, the state, the alarm and a refusal in the catalogue's words", async () => {
  await page.locator('button[data-screen="automatic"]').tap();
  const key = page.locator('[data-testid="language"]');
  assert.equal(await key.getAttribute("data-lang"), "en");
  assert.equal(await key.innerText(), "Deutsch");
  await key.tap();
  await waitFor("the panel in German", async () => (await key.getAttribute("data-lang")) === "de", 5000);
  assert.equal(await text('button[data-screen="diagnostics"]'), "DIAGNOSE");
  assert.equal(await text('[data-testid="state"]'), "STÖRUNG");
  // The server's words: from the next frame on.
  await waitFor("the alarm in German", async () => /Antriebsstörung Y/.test(await text('[data-testid="alarm"]')), 5000);
  assert.equal(await text('[data-testid="alarm-drive-reported"]'), "Antrieb Y meldete EMCY 0x2310 Dauerüberstrom");
  const banner = await text('[data-testid="alarm"]');
  assert.match(banner, /kein Zyklus lief/);
  assert.match(banner, /EMCY-Meldung des Antriebs in DIAGNOSE/);
  // No English sentence left on the status line or AUTOMATIC (names and units aside).
  const all = `${await text('[data-testid="status"]')}\n${await text("main")}`;
  assert.doesNotMatch(all, /\b(the|and|is|refused|remedy|continue|state|pass|program)\b/, all);
  // A refusal of the loop, in German: RESUME while the machine stands in fault.
  await page.locator('[data-testid="resume"]').tap();
  const refused = page.locator('[data-testid="toast"].refused').first();
  await refused.waitFor({ timeout: 10000 });
  const said = await refused.innerText();
  assert.match(said, /ABGELEHNT/);
  assert.match(said, /die Maschine ist in Störung/);
  await shot(page, "alarm-german");
  await key.tap();
  await waitFor("the panel in English again", async () => (await key.getAttribute("data-lang")) === "en", 5000);
  await waitFor("the alarm in English again", async () => /drive fault Y/.test(await text('[data-testid="alarm"]')), 5000);
});

test("repaired and RESET on the panel, the alarm clears and the machine is idle", async () => {
  sim("clear");
  await new Promise((r) => setTimeout(r, 1000));
  await page.locator('[data-testid="cmd-reset"]').tap();
  await waitFor("idle without an alarm (hob status)", () => { const s = status(); return s.state === "idle" && s.alarm === ""; }, 60000, 500);
  await waitFor("the banner gone", async () => (await page.locator('[data-testid="alarm"]').count()) === 0, 5000);
});
