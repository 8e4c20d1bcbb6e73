// hob-hmi is not part of the control: killed mid-cut, the loop cuts on without an alarm,
// the page says its server is gone (never shows old values as live), and a restarted
// server resynchronises the page with the events of the outage, none twice.
import { test, after } from "node:test";
import assert from "node:assert/strict";
import { startHmi, browser, status, waitFor, shot, hob } from "./lib/hmi.mjs";

let hmi = await startHmi();
const ctx = await browser();
after(async () => { await ctx.close(); hmi.proc.kill("SIGTERM"); });

test("kill -9 of hob-hmi mid-cut changes nothing in the loop; the page resynchronises after the restart", async () => {
  const page = await ctx.newPage();
  await page.goto(`${hmi.url}#alarms`);
  await page.waitForSelector('[data-testid="age"]', { timeout: 20000 });
  const s0 = status();
  assert.ok(s0.x_referenced && s0.program_loaded, "the earlier tests referenced and loaded");
  hob("start", "--single");
  await waitFor("the cut (hob status)", () => status().state === "cut", 120000, 200);
  hmi.proc.kill("SIGKILL");
  await page.locator('[data-testid="stale"]').waitFor({ timeout: 3000 });
  assert.match(await page.locator('[data-testid="stale"]').innerText(), /HMI SERVER NOT ANSWERING/);
  await shot(page, "stale");
  await new Promise((r) => setTimeout(r, 1000));
  const during = status();
  assert.equal(during.alarm, "", `an alarm while the HMI was gone: ${during.alarm}`);
  assert.notEqual(during.state, "fault");
  hmi = await startHmi(hmi.port);
  await page.locator('[data-testid="age"]').waitFor({ timeout: 10000 });
  await waitFor("the single pass done", () => status().state === "idle", 300000, 500);
  await new Promise((r) => setTimeout(r, 500));
  const seqs = await page.locator('[data-testid="event"] td:first-child').allInnerTexts();
  const unique = new Set(seqs);
  assert.equal(unique.size, seqs.length, `events listed twice: ${seqs.join(",")}`);
  const texts = (await page.locator('[data-testid="event"]').allInnerTexts()).join("\n");
  assert.match(texts, /cycle done/, "the end of the pass is missing from the page");
  await shot(page, "alarms");
  // Older than the restarted server's memory: OLDER pages back through its ring, then the
  // logger's record, down to this run's first event, each once and none missing.
  const fresh = await ctx.newPage();
  await fresh.goto(`${hmi.url}#alarms`);
  await fresh.waitForSelector('[data-testid="event"]', { timeout: 10000 });
  const older = fresh.locator('[data-testid="older-events"]');
  for (let i = 0; i < 30 && (await older.innerText()) === "OLDER"; i++) {
    await older.tap();
    // Until its answer is in (live events may add rows meanwhile).
    await waitFor("the older page", async () => (await older.getAttribute("data-loading")) === "no", 5000, 50);
  }
  // A row of repeated bus events folded into one says its first and last number.
  const numbers = (cells) => cells.flatMap((t) => {
    const [a, b] = t.split("..").map(Number);
    return b === undefined ? [a] : Array.from({ length: b - a + 1 }, (_, i) => a + i);
  });
  const all = numbers(await fresh.locator('[data-testid="event"] td:first-child').allInnerTexts());
  assert.equal(new Set(all).size, all.length, `events listed twice: ${all.join(",")}`);
  const lo = Math.min(...all), hi = Math.max(...all);
  assert.equal(lo, 1, `OLDER did not reach the run's first event: ${all.join(",")}`);
  assert.equal(all.length, hi - lo + 1, `events missing between ${lo} and ${hi}: ${all.join(",")}`);
  console.log(`OLDER: ${all.length} events, 1..${hi}; ${await fresh.locator('[data-testid="older-note"]').allInnerTexts()}`);
  // The log filtered by axis, kind and severity (the class of each event is the server's).
  const rows = fresh.locator('[data-testid="event"]');
  await fresh.locator('[data-testid="filter-axis-X"]').tap();
  await waitFor("only X's events", async () => (await rows.count()) > 0 && (await rows.evaluateAll((r) => r.every((x) => x.dataset.axis === "X"))), 5000);
  assert.match((await rows.allInnerTexts()).join("\n"), /referenced|X/, "X's referencing is in the log");
  await fresh.locator('[data-testid="filter-axis-all"]').tap();
  await fresh.locator('[data-testid="filter-group-operator"]').tap();
  await waitFor("only the operator's commands", async () => (await rows.count()) > 0 && (await rows.evaluateAll((r) => r.every((x) => x.children[2].textContent === "operator"))), 5000);
  await fresh.locator('[data-testid="filter-severity-warning"]').tap();
  await waitFor("the operator's refusals", async () => (await rows.count()) > 0 && (await rows.evaluateAll((r) => r.every((x) => x.dataset.severity === "warning" || x.dataset.severity === "alarm"))), 5000);
  assert.match((await rows.allInnerTexts()).join("\n"), /refused/);
  await shot(fresh, "alarms-filtered");
  // However long the status line's words ("loaded elsewhere (plan unknown here)"), RESET
  // stays whole on the screen (it was pushed off at 1280 px).
  const reset = await fresh.locator('header [data-testid="cmd-reset"]').boundingBox();
  const width = fresh.viewportSize().width;
  assert.ok(reset && reset.x >= 0 && reset.x + reset.width <= width, `RESET at ${JSON.stringify(reset)} in ${width} px`);
  await fresh.close();
  // DIAGNOSTICS: the loop's timing from its stats, the drives, every named signal.
  await page.locator('nav [data-screen="diagnostics"]').tap();
  await page.locator('[data-testid="overruns"]').waitFor({ timeout: 5000 });
  assert.equal(await page.locator('[data-signal]').count(), 23, "15 inputs and 8 outputs of the machine file");
  await shot(page, "diagnostics");
  await page.locator('nav [data-screen="jog"]').tap();
  await page.setViewportSize({ width: 1920, height: 1080 });
  await shot(page, "jog-1920x1080");
  await page.close();
});
