// COMPENSATE on the gear 03 cut: the simulated machine's gear checker (`hob-lab check`, from
// the log and hob-sim's truth beside it) measures the finished gear into the measurements
// folder as the shop's checker would; at the panel the operator picks its file, the program
// and the cut, PREVIEW shows `hob compensate`'s findings, its plot and the file it would
// write, WRITE (the setter's panel) writes it beside the machine's state file, and the screen
// says to restart hob-rt. hob-rt is not restarted: the later tests cut nothing with it.
import { test, after } from "node:test";
import assert from "node:assert/strict";
import { readFileSync, writeFileSync, readdirSync, existsSync, rmSync, mkdtempSync } from "node:fs";
import { execFileSync } from "node:child_process";
import { tmpdir } from "node:os";
import { join, dirname } from "node:path";
import { startHmi, browser, need, shot } from "./lib/hmi.mjs";

const hmi = await startHmi();
const ctx = await browser();
const folder = need("HOB_MEASUREMENTS_DIR");
const scratch = mkdtempSync(join(tmpdir(), "hob-hmi-check-"));
after(async () => { await ctx.close(); hmi.proc.kill("SIGTERM"); rmSync(scratch, { recursive: true, force: true }); });

// 03's program ("hmi test gear") is the session's gear typed in at the panel: the checker is
// given it as that file with 03's name (its teeth, module, face and pitch circle are the same).
const GEAR = "hmi test gear";

test("COMPENSATE after the cut: the checker's file of the gear, PREVIEW with the findings and the plot, WRITE, restart hob-rt", async () => {
  const session = readFileSync(need("HOB_SESSION_PROGRAM_FILE"), "utf8").replace(/^name = .*$/m, `name = "${GEAR}"`);
  const program = join(scratch, "gear.toml");
  writeFileSync(program, session);
  execFileSync(join(need("HOB_BIN"), "hob-lab"), ["check", "--log", need("HOB_LOG_DIR"), "--program", program,
    "--machine", need("HOB_MACHINE"), "--out", scratch, "--heights", "1"], { encoding: "utf8", timeout: 120000 });
  const measured = readFileSync(join(scratch, "measurement-1.csv"), "utf8");
  assert.match(measured, new RegExp(`^# gear: ${GEAR}$`, "m"));
  writeFileSync(join(folder, "gear-03.csv"), measured);
  const written = join(dirname(need("HOB_STATE_FILE")), "pitch-compensation");
  const page = await ctx.newPage();
  try {
    await page.goto(`${hmi.url}#compensate`);
    const key = page.locator('[data-testid="compensate-files"] [data-file="gear-03.csv"]');
    await key.waitFor({ timeout: 20000 });
    await key.tap();
    await page.locator('[data-testid="compensate-program"]').selectOption("hmi-gear");
    await page.locator('[data-testid="compensate-preview"]').tap();
    await page.locator('[data-testid="compensate-result"][data-state="preview"]').waitFor({ timeout: 60000 });
    const text = await page.locator('[data-testid="compensate-text"]').innerText();
    for (const words of [`hob compensate: ${GEAR}, 17 teeth, 1-start hob`, "the table's error:", "a compensation removes f_pt",
      "(new):", "not written (run again with --yes to write it)"]) assert.ok(text.includes(words), `${words} not in:\n${text}`);
    assert.ok(await page.locator('[data-testid="compensate-plot"] svg polyline').count() > 0, "no plot");
    assert.deepEqual(existsSync(written) ? readdirSync(written) : [], [], "PREVIEW wrote");
    await shot(page, "compensate-preview");
    await page.locator('[data-testid="compensate-write"]').tap();
    await page.locator('[data-testid="compensate-result"][data-state="written"]').waitFor({ timeout: 60000 });
    assert.match(await page.locator('[data-testid="compensate-restart"]').innerText(), /Restart hob-rt for the loop to load it/);
    const after = await page.locator('[data-testid="compensate-text"]').innerText();
    assert.match(after, /^written: .*pitch-compensation\/B-2019-07\.toml$/m);
    assert.deepEqual(readdirSync(written), ["B-2019-07.toml"]);
    assert.match(readFileSync(join(written, "B-2019-07.toml"), "utf8"), new RegExp(`^gear = "${GEAR}"$`, "m"));
    assert.equal(await page.locator('[data-testid="compensate-write"]').isDisabled(), true, "WRITE again without a PREVIEW");
    await shot(page, "compensate-written");
  } finally {
    await page.close();
  }
});
