// Power-up, referencing, press-and-hold jog with its dead-man, touch-off: through the page in
// Chromium, checked against the loop's own state (`hob status --json`).
import { test, after } from "node:test";
import assert from "node:assert/strict";
import { readFileSync } from "node:fs";
import { join } from "node:path";
import { startHmi, browser, status, waitFor, shot, touchHold, need, hob } from "./lib/hmi.mjs";

const hmi = await startHmi();
const ctx = await browser();
after(async () => { await ctx.close(); hmi.proc.kill("SIGTERM"); });

const open = async (screen) => {
  const page = await ctx.newPage();
  await page.goto(`${hmi.url}#${screen}`);
  await page.waitForSelector('[data-testid="age"]', { timeout: 20000 });
  return page;
};

test("power-up shows the safety chain, the drives and referencing; HOME ALL references X and Y", async () => {
  const page = await open("powerup");
  await waitFor("the drives enabled on the page", async () => (await page.locator('[data-testid="drive-Y"].ok').count()) === 1, 60000);
  assert.equal(await page.locator('[data-testid="chain"].ok').count(), 1, "the safety chain is closed in the simulated machine");
  const before = status();
  assert.equal(before.x_referenced, false);
  assert.match(await page.locator('[data-testid="referenced"]').innerText(), /X ✗ Y ✗/);
  await shot(page, "power-up");
  await page.locator('[data-testid="home-all"]').tap();
  await waitFor("X and Y referenced (hob status)", () => { const s = status(); return s.x_referenced && s.y_referenced && s.state === "idle"; }, 240000, 500);
  await waitFor("the page shows the reference", async () => /X ✓ Y ✓/.test(await page.locator('[data-testid="referenced"]').innerText()), 5000);
  await page.close();
});

test("PROGRAMS lists the library with each program's state; LOAD loads one into the loop", async () => {
  const page = await open("programs");
  const row = page.locator('[data-program="session-gear"]');
  await row.waitFor({ timeout: 10000 });
  assert.match(await row.innerText(), /valid/);
  assert.equal(status().program_loaded, false);
  await page.locator('[data-testid="load-session-gear"]').tap();
  await page.locator('[data-testid="toast"].ok').first().waitFor({ timeout: 10000 });
  await waitFor("the program loaded in the loop", () => status().program_loaded, 5000);
  // The loop publishes the hash of the text it was given: the status line names the program.
  assert.match(status().program_hash || "", /^[0-9a-f]{16}$/);
  await waitFor("the status line names the loaded program", async () =>
    (await page.locator('[data-testid="loaded-program"]').innerText()).includes("session-gear"), 5000);
  await shot(page, "programs");
  await page.close();
});

test("holding X- jogs X; lifting the finger stops it at once, not by the dead-man", async () => {
  const page = await open("jog");
  const x0 = status().x_mm;
  const t = await touchHold(page, '[data-jog="x-"]', 1500);
  const moving = status();
  assert.equal(moving.state, "jog", `state while held: ${moving.state}`);
  assert.ok(moving.x_mm < x0 - 0.5, `X ${moving.x_mm} mm, was ${x0}: it did not move`);
  await shot(page, "jog");
  await t.lift();
  const lifted = Date.now();
  await waitFor("X stopped after the lift", () => status().state === "idle", 3000, 50);
  const stopMs = Date.now() - lifted;
  const s = status();
  const texts = s.events.map((e) => e.text).join("\n");
  assert.doesNotMatch(texts, /dead-man/, "the release stopped it, not the dead-man");
  console.log(`X stopped ${stopMs} ms after the finger lifted (X ${s.x_mm.toFixed(3)} mm)`);
  const x1 = s.x_mm;
  await new Promise((r) => setTimeout(r, 500));
  assert.ok(Math.abs(status().x_mm - x1) < 0.01, "X still moves after the stop");
  await page.close();
});

test("closing the page while holding Y+ stops Y", async () => {
  const page = await open("jog");
  await touchHold(page, '[data-jog="y+"]', 800);
  assert.equal(status().state, "jog");
  await page.close();
  await waitFor("Y stopped after the page closed", () => status().state === "idle", 3000, 50);
});

test("holding C turns the hob spindle; lifting stops it, and so does closing the page", async () => {
  const page = await open("jog");
  await page.locator('[data-testid="spindle-rpm"]').fill("20");
  const t = await touchHold(page, '[data-jog="c+"]', 1500);
  const held = status();
  // The measured speed carries the hob's sense in the frame (negative on this machine).
  assert.ok(Math.abs(held.spindle_rpm) > 10, `spindle ${held.spindle_rpm} rpm while held at 20`);
  assert.equal(held.state, "idle", "a held spindle is no jog of an axis");
  await t.lift();
  await waitFor("the spindle stopped after the lift", () => Math.abs(status().spindle_rpm) < 0.5, 5000, 50);
  assert.doesNotMatch(status().events.map((e) => e.text).join("\n"), /spindle C stopped: its renewals/, "released, not the dead-man");
  // Held again and the page closed: released by the server (or else by the loop's dead-man).
  await touchHold(page, '[data-jog="c+"]', 1000);
  assert.ok(Math.abs(status().spindle_rpm) > 5, "turning again");
  await page.close();
  await waitFor("the spindle stopped after the page closed", () => Math.abs(status().spindle_rpm) < 0.5, 5000, 50);
});

test("DIAGNOSTICS shows each CAN node's NMT state and each drive's CiA 402 state as the loop reports them", async () => {
  const page = await open("diagnostics");
  const loop = status();
  for (const [node, want] of Object.entries(loop.drives)) {
    const name = node === "io" ? "I/O" : node;
    const row = page.locator(`[data-node="${name}"]`);
    await row.waitFor({ timeout: 5000 });
    const text = await row.innerText();
    assert.match(text, new RegExp(want.nmt), `${name}: ${text}`);
    if (want.cia402) assert.match(text, new RegExp(want.cia402), `${name}: ${text}`);
  }
  assert.equal(loop.drives.B.nmt, "operational");
  assert.equal(loop.drives.Y.cia402, "operation enabled");
  await page.locator('[data-testid="wake-histogram"] .bar').first().waitFor({ timeout: 5000 });
  await shot(page, "diagnostics-nodes");
  await page.close();
});

// The figures a touch-off's answer names: the old and new offset and the change (mm).
const FIGURES = /X offset ([+-]\d+\.\d{4}) mm -> ([+-]\d+\.\d{4}) mm \(change ([+-]\d+\.\d{4}) mm\)/;

test("touch-off X: the offsets on the panel; a typo is refused with the offset it would set and changes nothing; CANCEL leaves it, CONFIRM sets exactly that offset", async () => {
  const page = await open("jog");
  const before = status();
  const touch = async (gauge) => {
    await page.locator('[data-testid="touch-x-value"]').fill(String(gauge));
    await page.locator('[data-testid="touch-x"]').tap();
  };
  const shown = async () => Number(await page.locator('[data-testid="touch-offset-x"]').innerText());
  // The offsets are on the touch-off panel itself, as the loop has them.
  await waitFor("the panel's X offset", async () => Math.abs((await shown()) - before.x_offset_mm) < 1e-4, 5000);
  // A thousands separator is not a number: refused in words naming the field, nothing sent.
  await touch("1.094,940");
  await page.locator('[data-testid="touch-answer"].bad').waitFor({ timeout: 10000 });
  assert.match(await page.locator('[data-testid="touch-answer"]').innerText(), /REFUSED: X: gauge diameter: "1\.094,940" is not a number/);
  // Absurd: refused with the loop's reason, even before any question.
  await touch(100000);
  await waitFor("the loop's refusal on the panel", async () => /REFUSED: touch-off refused: the value is not a finite number in range/.test(await page.locator('[data-testid="touch-answer"].bad').innerText()), 10000);
  assert.equal(status().x_offset_mm, before.x_offset_mm, "a refused touch-off changed the offset");

  // The hob's tip onto the blank, 0.1 mm beyond its outside diameter (set-up of the test:
  // the loop's own jog through the CLI, as the keys would send it).
  const tip = Number(need("HOB_TOOL_TIP_MM"));
  const blank = Number(need("HOB_BLANK_OD_MM"));
  const onBlank = (blank + tip) / 2 + 0.1;
  hob("jog", "x", (onBlank - before.x_mm).toFixed(4));
  await waitFor("X on the blank", () => { const s = status(); return s.state === "idle" && Math.abs(s.x_mm - onBlank) < 0.01; }, 30000, 200);
  // The blank's own diameter, typed on the panel's keypad with a decimal comma as a German
  // shop types it: plausible, applied unasked; the answer names the change.
  const field = page.locator('[data-testid="touch-x-value"]');
  await field.fill("");
  await field.tap();
  await page.locator('[data-testid="keypad"]').waitFor({ timeout: 3000 });
  const typed = blank.toFixed(3).replace(".", ",");
  for (const k of typed) await page.locator(`[data-key-pad="${k}"]`).tap();
  assert.equal(await field.inputValue(), typed);
  for (const k of ["7", ",", "ENTER"]) {
    const box = await page.locator(`[data-key-pad="${k}"]`).boundingBox();
    assert.ok(box.width >= 48 && box.height >= 48, `keypad key ${k}: ${box.width} x ${box.height} px`);
  }
  await shot(page, "keypad");
  await page.locator('[data-key-pad="ENTER"]').tap();
  await page.locator('[data-testid="keypad"]').waitFor({ state: "detached", timeout: 3000 });
  await page.locator('[data-testid="touch-x"]').tap();
  await waitFor("the offset near -0.1 mm", () => Math.abs(status().x_offset_mm - (before.x_offset_mm - 0.1)) < 0.01, 5000);
  const first = status().x_offset_mm;
  await waitFor("the accepted answer on the panel", async () => /touch-off X: accepted; X offset .* -> .* \(change -0\.\d{4} mm\)/.test(await page.locator('[data-testid="touch-answer"].ok').innerText()), 5000);
  assert.equal(await page.locator('[data-testid="touch-confirm"]').count(), 0, "a plausible touch-off asked");

  // The typo of issue 32: a 1 typed in front of the blank's diameter.
  const typo = blank + 100;
  await touch(typo);
  const dialog = page.locator('[data-testid="touch-confirm"]');
  await dialog.waitFor({ timeout: 10000 });
  const asked = await page.locator('[data-testid="touch-confirm-text"]').innerText();
  assert.match(asked, /touch-off refused: this touch-off does not fit what the machine knows/);
  assert.match(asked, new RegExp(`the gauge, ${typo.toFixed(3)} mm, is 100\\.000 mm larger than the loaded blank's outside diameter, ${blank.toFixed(3)} mm`));
  const m = asked.match(FIGURES);
  assert.ok(m, `no figures in: ${asked}`);
  const change = Number(m[3]);
  assert.ok(Math.abs(Number(m[1]) - first) < 1e-4, `old ${m[1]}, the loop has ${first}`);
  assert.ok(Math.abs(change - 50) < 0.01, `change ${change}`);
  await shot(page, "touch-off-confirm");
  // Nothing changed while the loop asks.
  await new Promise((r) => setTimeout(r, 500));
  assert.equal(status().x_offset_mm, first, "the offset changed before a confirmation");
  assert.ok(Math.abs((await shown()) - first) < 1e-4);
  // CANCEL: the dialog goes, nothing changes.
  await page.locator('[data-testid="touch-cancel"]').tap();
  await waitFor("the dialog closed", async () => (await dialog.count()) === 0, 5000);
  assert.match(await page.locator('[data-testid="touch-answer"]').innerText(), /CANCELLED, nothing changed/);
  assert.equal(status().x_offset_mm, first, "CANCEL changed the offset");
  // Asked again, CONFIRM: the loop sets exactly the offset it named this time (X may
  // stand a count further than at the first question: the offset follows it).
  await touch(typo);
  await dialog.waitFor({ timeout: 10000 });
  const again = (await page.locator('[data-testid="touch-confirm-text"]').innerText()).match(FIGURES);
  assert.ok(again, "no figures in the second question");
  const named = Number(again[2]);
  await page.locator('[data-testid="touch-confirm-yes"]').tap();
  await waitFor("the dialog closed after CONFIRM", async () => (await dialog.count()) === 0, 10000);
  await waitFor("the confirmed offset in the loop", () => status().x_offset_mm !== first, 5000);
  const set = status().x_offset_mm;
  assert.equal(set.toFixed(4), named.toFixed(4), `the loop set ${set}, the dialog named ${named}`);
  const ok = await page.locator('[data-testid="touch-answer"].ok').innerText();
  assert.match(ok, new RegExp(`touch-off X: accepted; X offset .* -> ${again[2].replace("+", "\\+")} mm`));
  await waitFor("the panel shows the new offset", async () => (await shown()).toFixed(4) === named.toFixed(4), 5000);
  // Put right: the blank's diameter again is a 50 mm change, asked about and confirmed.
  await touch(blank);
  await dialog.waitFor({ timeout: 10000 });
  await page.locator('[data-testid="touch-confirm-yes"]').tap();
  await waitFor("the offset back", () => Math.abs(status().x_offset_mm - first) < 1e-3, 10000);
  await page.locator('[data-testid="touch-answer"].ok').waitFor({ timeout: 5000 });
  // The panel in view with its offsets and the answer (the page's own scroller, not the body).
  await page.locator('[data-testid="touch-offsets"]').evaluate((e) => { const main = e.closest("main"); main.scrollTop += e.closest(".card").getBoundingClientRect().top - main.getBoundingClientRect().top - 8; });
  await shot(page, "touch-off");
  await page.close();
});

test("a flank touch is the loop's to check: refused while the spindle turns, taken with it still", async () => {
  const page = await open("jog");
  assert.equal(status().program_loaded, true, "the program loaded above");
  await page.locator('[data-testid="spindle-rpm"]').fill("20");
  await page.locator('[data-testid="cmd-spindle"]').first().tap();
  await waitFor("the spindle turning", () => Math.abs(status().spindle_rpm) > 5, 30000);
  await page.locator('[data-testid="touch-flank-minus"]').tap();
  const refused = page.locator('[data-testid="toast"].refused', { hasText: "FLANK AT B" });
  await refused.first().waitFor({ timeout: 10000 });
  assert.match(await refused.first().innerText(), /REFUSED: touch flank refused: the spindle turns/);
  assert.equal(await refused.first().getAttribute("data-refusal"), "spindle-turning");
  await page.locator('[data-testid="cmd-spindle"]').nth(1).tap();
  await waitFor("the spindle standing", () => Math.abs(status().spindle_rpm) < 0.05, 60000);
  await page.locator('[data-testid="touch-flank-minus"]').tap();
  await page.locator('[data-testid="toast"].ok', { hasText: "FLANK AT B" }).first().waitFor({ timeout: 10000 });
  // The loop's event, as the logger recorded it (a fresh `hob status` may come before the
  // loop hands it the events' history).
  const events = join(need("HOB_LOG_DIR"), "events.log");
  await waitFor("the touch in the loop's events (the logger's events.log)", () => readFileSync(events, "utf8").includes("flank touched, the table turned negative"), 10000);
  await shot(page, "align");
  await page.close();
});
