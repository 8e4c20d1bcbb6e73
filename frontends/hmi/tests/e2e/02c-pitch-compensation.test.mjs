// The pitch compensation beside CYCLE START (AUTOMATIC) and START SINGLE (SINGLE): the page
// shows the loop's state of it and a key to switch it. The suite's hob-rt has none stored for
// the machine's worm set (table.worm_set "B-2019-07", nothing under pitch-compensation/ beside
// its state file), so the loop says NONE: the key is shown unavailable with the reason, and
// pressed anyway it sends the loop's command, which the loop refuses (no-compensation) in its
// own words in the answers' row; nothing changes. (OFF and ON need a hob-rt started with a
// stored compensation: the server's test shows them from a fake loop's samples.)
//
// It runs with the machine idle, after the commissioning keys (02b) and before the cut (03):
// in a cycle the loop would refuse the switch as cycle-running first.
import { test, after } from "node:test";
import assert from "node:assert/strict";
import { startHmi, browser, status, waitFor, shot } from "./lib/hmi.mjs";

const hmi = await startHmi();
const ctx = await browser();
after(async () => { await ctx.close(); hmi.proc.kill("SIGTERM"); });

const NO_COMPENSATION = "no pitch compensation was loaded for this machine's worm set: measure a gear, run hob compensate, then restart hob-rt";

test("PITCH COMP: NONE from the loop before START; its key, pressed anyway, gets the loop's no-compensation refusal and changes nothing", async () => {
  const page = await ctx.newPage();
  try {
    await page.goto(`${hmi.url}#automatic`);
    const ind = page.locator('[data-testid="pitch-comp"]');
    await waitFor("the loop's pitch compensation on AUTOMATIC", async () => (await ind.getAttribute("data-state")) === "none", 20000, 100);
    assert.equal(await page.locator('[data-testid="pitch-comp-state"]').innerText(), "NONE");
    assert.match(await ind.innerText(), /^PITCH COMP: NONE\b/);
    const key = page.locator('[data-testid="pitch-comp-key"]');
    assert.equal(await key.innerText(), "PITCH COMP ON");
    assert.match(await key.getAttribute("class"), /\bunavailable\b/, "the key is not shown unavailable");
    assert.equal(await key.isDisabled(), false, "the key is dark: the loop is to answer it");
    assert.equal(await page.locator('[data-testid="pitch-comp-why"]').innerText(), "no compensation stored for this worm set: run hob compensate");
    // On the same row as the cycle's keys: seen before CYCLE START without scrolling.
    const start = await page.locator('[data-testid="start-auto"]').boundingBox();
    const box = await ind.boundingBox();
    assert.ok(box.y > start.y && box.y - start.y < 120 && box.y + box.height < 800, `the indicator at y ${box.y}, CYCLE START at ${start.y}`);
    const s0 = status();
    assert.equal(s0.state, "idle", "the machine is not idle before the test");
    await key.tap();
    const refused = page.locator('[data-testid="toast"].refused');
    await refused.first().waitFor({ timeout: 10000 });
    assert.equal(await refused.first().getAttribute("data-refusal"), "no-compensation");
    // The loop's answer as it gave it ("pitch compensation refused: " and its refusal's text).
    const said = await refused.first().innerText();
    assert.ok(said.startsWith("PITCH COMP ON: REFUSED: ") && said.endsWith(NO_COMPENSATION), said);
    await shot(page, "pitch-comp-none");
    // Nothing changed: the loop's state, alarm and pass, and its pitch compensation a few
    // frames later (the page's only source of it is the loop's state sample).
    const s = status();
    assert.equal(s.state, s0.state, "the loop's state after the refusal");
    assert.equal(s.alarm, s0.alarm, "the loop's alarm after the refusal");
    assert.equal(s.pass, s0.pass);
    if ("pitch_compensation" in s) assert.equal(s.pitch_compensation, "none");
    await page.waitForTimeout(300);
    assert.equal(await ind.getAttribute("data-state"), "none");
    assert.equal(await key.innerText(), "PITCH COMP ON");
    // SINGLE, the other screen that starts a cut, shows the same.
    await page.locator('nav [data-screen="single"]').tap();
    await waitFor("the indicator on SINGLE", async () => (await page.locator('[data-testid="pitch-comp"]').getAttribute("data-state")) === "none", 5000, 100);
    assert.equal(await page.locator('[data-testid="pitch-comp-state"]').innerText(), "NONE");
  } finally {
    await page.close();
  }
});
