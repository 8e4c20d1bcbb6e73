// COMPENSATE: `hob compensate` from the panel. A gear checker's file of another gear is put
// into the measurements folder (HOB_MEASUREMENTS_DIR, hob-hmi's --measurements-dir); the
// screen lists it, the operator picks it and the program, PREVIEW runs the CLI beside
// hob-hmi, and its refusal (exit 2) is shown word for word: the same words `hob compensate`
// says run by hand with the same files. Nothing is held for WRITE and nothing is written
// beside the machine's state file.
//
// It runs with the machine idle, before the cut (03): it commands nothing. 03b computes and
// writes a compensation from the gear 03 cut.
import { test, after } from "node:test";
import assert from "node:assert/strict";
import { writeFileSync, readdirSync, rmSync } from "node:fs";
import { execFileSync } from "node:child_process";
import { join, dirname } from "node:path";
import { startHmi, browser, need, waitFor, shot } from "./lib/hmi.mjs";

const hmi = await startHmi();
const ctx = await browser();
const folder = need("HOB_MEASUREMENTS_DIR");
const file = join(folder, "other-gear.csv");
after(async () => { await ctx.close(); hmi.proc.kill("SIGTERM"); rmSync(file, { force: true }); });

/** A checker's file (docs/gear-measurement.md) of a 17-tooth gear named `gear`, every pitch
 *  deviation 0. */
function measurement(gear) {
  const head = ["# hob gear measurement 1", `# gear: ${gear}`, "# teeth: 17", "# normal_module_mm: 5", "# face_position_mm: 2.000",
    "# tooth_1_table_deg: 10.588235", "# counting: table_positive", "# checker: browser test", "# measured_at: 2026-11-29T12:00:00Z",
    "tooth,left_fp_um,right_fp_um,left_Fp_um,right_Fp_um"];
  const rows = Array.from({ length: 17 }, (_, i) => `${i + 1},0.000,0.000,0.000,0.000`);
  return [...head, ...rows, ""].join("\n");
}

test("COMPENSATE: a measurement of another gear picked, PREVIEW gets hob compensate's refusal word for word, nothing written", async () => {
  writeFileSync(file, measurement("Spur z99"));
  const page = await ctx.newPage();
  try {
    await page.goto(`${hmi.url}#compensate`);
    const key = page.locator('[data-testid="compensate-files"] [data-file="other-gear.csv"]');
    await key.waitFor({ timeout: 20000 });
    await page.locator('[data-testid="compensate-program"]').selectOption("session-gear");
    const preview = page.locator('[data-testid="compensate-preview"]');
    assert.equal(await preview.isDisabled(), true, "PREVIEW without a measurement picked");
    await key.tap();
    assert.match(await key.getAttribute("class"), /\bon\b/);
    await preview.tap();
    const result = page.locator('[data-testid="compensate-result"][data-state="refused"]');
    await result.waitFor({ timeout: 30000 });
    const shown = await page.locator('[data-testid="compensate-text"]').innerText();
    // The CLI by hand, with the files the screen named: its standard error, exit 2.
    const args = ["compensate", "--machine", need("HOB_MACHINE"), "--program", join(need("HOB_LIBRARY"), "programs", "session-gear.toml"),
      "--log", need("HOB_LOG_DIR"), "--measurement", file];
    let said = null;
    try {
      execFileSync(join(need("HOB_BIN"), "hob"), args, { encoding: "utf8", stdio: ["ignore", "pipe", "pipe"], timeout: 60000 });
    } catch (e) {
      assert.equal(e.status, 2, `hob compensate by hand: ${e.stderr}`);
      said = e.stderr.trimEnd();
    }
    assert.ok(said && said.startsWith(`hob: refused: ${file}: gear: the measurement is of "Spur z99", the program cuts `), said);
    assert.equal(shown, said, "the page's refusal is not the CLI's");
    await shot(page, "compensate-refused");
    assert.equal(await page.locator('[data-testid="compensate-write"]').isDisabled(), true, "WRITE after a refusal");
    const over = await page.evaluate(async () => (await fetch("/api/compensate")).json());
    assert.equal(over.held, null, "a refusal held a request for WRITE");
    assert.deepEqual(readdirSync(join(dirname(need("HOB_STATE_FILE")), "pitch-compensation")), [], "a compensation was written");
  } finally {
    await page.close();
  }
});
