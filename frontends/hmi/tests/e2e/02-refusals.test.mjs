// Bad input through the page gets the Rust checks' or the loop's refusal, shown where it
// belongs, and changes nothing: not the library on disk, not the loop.
import { test, after } from "node:test";
import assert from "node:assert/strict";
import { statSync, readFileSync, writeFileSync } from "node:fs";
import { join } from "node:path";
import { startHmi, browser, status, waitFor, shot, need } from "./lib/hmi.mjs";

const hmi = await startHmi();
const ctx = await browser();
after(async () => { await ctx.close(); hmi.proc.kill("SIGTERM"); });

const open = async (screen) => {
  const page = await ctx.newPage();
  await page.goto(`${hmi.url}#${screen}`);
  await page.waitForSelector('[data-testid="age"]', { timeout: 20000 });
  return page;
};

test("a typo in the teeth is refused on its field by the program's own check, and nothing is written", async () => {
  const file = join(need("HOB_LIBRARY"), "programs", "session-gear.toml");
  const before = { text: readFileSync(file, "utf8"), mtime: statSync(file).mtimeMs };
  const page = await open("programs");
  await page.locator('[data-program="session-gear"] >> text=EDIT').tap();
  const teeth = page.locator('[data-key="workpiece.teeth"]');
  await waitFor("the program's fields", async () => (await teeth.inputValue()) === "17", 10000);
  await waitFor("every sub-menu green", async () => (await page.locator('.submenu[data-state="ok"]').count()) === 4, 10000);
  await teeth.fill("1O");
  await waitFor("WORKPIECE red", async () => (await page.locator('.submenu[data-section="workpiece"]').getAttribute("data-state")) === "invalid", 10000);
  const why = page.locator('[data-problem="workpiece.teeth"]');
  await why.waitFor({ timeout: 5000 });
  const message = await why.innerText();
  // In words, not serde's (it said: invalid type: string "1O", expected i64).
  assert.equal(message, '"1O" is not a whole number');
  assert.equal(await page.locator('.submenu[data-section="tool"]').getAttribute("data-state"), "ok", "a typo in WORKPIECE turned TOOL red");
  assert.equal(await page.locator('[data-testid="go-automatic"]').isDisabled(), true, "AUTOMATIC can start with a red sub-menu");
  await shot(page, "definition-refused");
  await page.locator('[data-testid="save"]').tap();
  await page.locator('[data-testid="save-answer"].bad').waitFor({ timeout: 5000 });
  const after_ = { text: readFileSync(file, "utf8"), mtime: statSync(file).mtimeMs };
  assert.deepEqual(after_, before, "the library's file changed after a refused save");
  await page.close();
});

test("a spindle speed above the machine's is refused by the loop, shown with its reason, and the spindle stays still", async () => {
  const page = await open("jog");
  const s0 = status();
  await page.locator('[data-testid="spindle-rpm"]').fill("100000");
  await page.locator('[data-testid="cmd-spindle"]').first().tap();
  const refused = page.locator('[data-testid="toast"].refused');
  await refused.first().waitFor({ timeout: 10000 });
  const text = await refused.first().innerText();
  assert.match(text, /REFUSED/);
  await shot(page, "refused-spindle");
  const s = status();
  assert.ok(Math.abs(s.spindle_rpm) < 0.5, `the spindle turns at ${s.spindle_rpm} rpm`);
  // The refusal changed nothing: the loop's state and alarm are as before. (The number of
  // events `hob status` returns is not a measure: a new subscriber gets the loop's history
  // when the loop next updates its connections.)
  assert.equal(s.state, s0.state, "the loop's state after the refusal");
  assert.equal(s.alarm, s0.alarm, "the loop's alarm after the refusal");
  await page.close();
});

test("a program changed in the library since LOAD is marked on the status line and the loop refuses its START", async () => {
  const file = join(need("HOB_LIBRARY"), "programs", "session-gear.toml");
  const original = readFileSync(file, "utf8");
  // LOAD it on this HMI (each test file starts its own hob-hmi, which knows only what it
  // loaded), then to AUTOMATIC.
  const page = await open("programs");
  await page.locator('[data-testid="load-session-gear"]').tap();
  await page.locator('[data-testid="toast"].ok').first().waitFor({ timeout: 10000 });
  await page.locator('nav [data-screen="automatic"]').tap();
  const loaded = page.locator('[data-testid="loaded-program"]');
  await waitFor("the status line names session-gear", async () => (await loaded.innerText()).includes("session-gear"), 10000);
  const mark = page.locator('[data-testid="changed-since-load"]');
  assert.equal(await mark.count(), 0, "marked changed before anything changed");
  const s0 = status();
  try {
    // The operator corrects the program in the library after LOAD (here: its part name).
    const edited = original.replace(/^name = "([^"]*)"/m, 'name = "$1, corrected"');
    assert.notEqual(edited, original, "the test's edit changed nothing");
    writeFileSync(file, edited);
    await mark.waitFor({ timeout: 10000 });
    await page.locator('[data-testid="start-auto"]').tap();
    const refused = page.locator('[data-testid="toast"].refused');
    await refused.first().waitFor({ timeout: 10000 });
    assert.match(await refused.first().innerText(), /changed since it was loaded/);
    await shot(page, "changed-since-load");
    const s = status();
    assert.equal(s.state, s0.state, "the loop's state after the refused START");
    assert.equal(s.pass, s0.pass);
  } finally {
    writeFileSync(file, original);
  }
  await waitFor("the mark gone with the file as loaded", async () => (await mark.count()) === 0, 10000);
  await page.close();
});
