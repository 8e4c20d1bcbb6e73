// Commissioning from DIAGNOSTICS: the table drive's lost motion (the TABLE BACKLASH key, the
// procedure of `hob commission backlash`, run by the HMI server with the held key as its
// enable), through a builder's page in Chromium against hob-sim. The suite's machine file
// names the gauge on the coupler's analog input 0 (bench/system-tests/tests/hmi.rs), where
// hob-sim's plant (config/plant.toml, peripherals.table_gauge) has one. Held to the end, the
// table jogs +, - and + slowly, the shipped plant's 10 arcsec backlash is found within 10 %,
// the fit and the diff with `[commissioning.table_backlash]` show, and WRITE writes that
// record, the old file kept (the test puts the file back as it was for the later tests).
//
// It runs here, before the cut (03): hob-sim's gauge reads 0 where the table stood at
// power-on and has +-0.6 deg of stroke, and a cut turns the table many times round.
import { test, after } from "node:test";
import assert from "node:assert/strict";
import { readFileSync, readdirSync, writeFileSync, unlinkSync } from "node:fs";
import { dirname, join } from "node:path";
import { startHmi, browser, status, waitFor, shot, touchHold, need } from "./lib/hmi.mjs";

const builder = await startHmi(0, { builder: true });
const ctx = await browser();
after(async () => { await ctx.close(); builder.proc.kill("SIGTERM"); });

const machine = need("HOB_MACHINE");
const baks = () => readdirSync(dirname(machine)).filter((f) => f.startsWith("machine.toml.") && f.endsWith(".bak"));

test("the table backlash's key held to the end: the plant's 10 arcsec found, the record proposed and written", async () => {
  const p = await ctx.newPage();
  try {
    await p.goto(`${builder.url}#diagnostics`);
    await p.locator('[data-testid="commission-backlash-hold"]').waitFor({ timeout: 20000 });
    assert.match(await p.locator('[data-testid="commission-backlash-gauge"]').innerText(), /on the coupler's analog input 0/);
    assert.match(await p.locator('[data-testid="commission-backlash"]').innerText(), /\+ at 3\.0 deg\/min for 5 s, then - and \+ again as long \(0\.250 deg each way, about 17 s in all\)/);
    const s0 = status();
    assert.equal(s0.state, "idle", "the machine is not idle before the test");
    assert.ok(Math.abs(s0.table_deg) < 0.3, `the table turned since power-on (${s0.table_deg} deg): beyond hob-sim's gauge`);
    // The shipped plant's backlash (hob-sim runs config/plant.toml in this suite).
    const hidden = Number(readFileSync("config/plant.toml", "utf8").match(/^backlash_arcsec = ([\d.]+)/m)[1]);
    assert.equal(hidden, 10, "config/plant.toml's backlash is not the 10 arcsec this test expects");
    const file = readFileSync(machine, "utf8");
    const st = p.locator('[data-testid="commission-backlash-state"]');
    const t0 = Date.now();
    const hold = await touchHold(p, '[data-testid="commission-backlash-hold"]', 0);
    await waitFor("the table jogging +", async () => /jogging the table \+/.test(await st.innerText()), 10000, 50);
    // The loop's truth, not the page's: the table jogs.
    const jogging = await waitFor("the loop jogging the table", () => { const s = status(); return s.state === "jog" ? s : null; }, 5000, 100);
    await waitFor("the proposal", async () => ["proposal", "stopped", "refused"].includes(await st.getAttribute("data-state")), 40000, 100);
    const held = await hold.lift();
    const said = await st.innerText();
    assert.equal(await st.getAttribute("data-state"), "proposal", said);
    const m = said.match(/the table drive's lost motion found: ([\d.]+) arcsec \(\+- ([\d.]+)\); proposed as \[commissioning\.table_backlash\]/);
    assert.ok(m, said);
    const [found, within] = [Number(m[1]), Number(m[2])];
    assert.ok(Math.abs(found - hidden) <= 0.1 * hidden, `found ${found} arcsec, the plant's backlash is ${hidden} arcsec`);
    const report = await p.locator('[data-testid="commission-report"]').innerText();
    assert.ok(report.includes(`lost motion of the table drive: ${m[1]} +- ${m[2]} arcsec`), report);
    const diff = await p.locator('[data-testid="commission-diff"]').innerText();
    assert.match(diff, /\+ *\d+ +\[commissioning\.table_backlash\]/);
    assert.ok(diff.includes(`lost_motion_arcsec = ${m[1]}`), diff);
    assert.equal(await p.locator('[data-testid="commission-proposal-of"]').getAttribute("data-procedure"), "backlash");
    assert.equal(await p.locator('[data-testid="commission-write"]').isDisabled(), false, "WRITE is dark on a builder's panel");
    assert.equal(readFileSync(machine, "utf8"), file, "the machine file changed before WRITE");
    await waitFor("the machine idle", () => status().state === "idle", 5000, 100);
    // The key's box with its result, WRITE, the fit and the diff on the screen together.
    await p.locator('[data-testid="commission-diff"]').evaluate((el) => el.scrollIntoView({ block: "end" }));
    await shot(p, "diagnostics-commissioning-backlash");
    const before = baks();
    await p.locator('[data-testid="commission-write"]').tap();
    await waitFor("written", async () => (await st.getAttribute("data-state")) === "written", 10000, 100);
    const written = readFileSync(machine, "utf8");
    const record = written.slice(written.indexOf("[commissioning.table_backlash]"));
    assert.ok(record.startsWith("[commissioning.table_backlash]"), "no record written");
    assert.ok(record.includes(`\nlost_motion_arcsec = ${m[1]}\n`) && record.includes(`\nuncertainty_arcsec = ${m[2]}\n`), record);
    const kept = baks().filter((f) => !before.includes(f));
    assert.equal(kept.length, 1, `kept: ${kept}`);
    assert.equal(readFileSync(join(dirname(machine), kept[0]), "utf8"), file, "the kept file is not the old one");
    // The later tests' machine file as it was (06 counts the files kept by its own WRITE).
    writeFileSync(machine, file);
    unlinkSync(join(dirname(machine), kept[0]));
    console.log(`backlash: found ${found} +- ${within} arcsec for the plant's ${hidden} arcsec; held ${held} ms (the loop in ${jogging.state}); ${((Date.now() - t0) / 1000).toFixed(1)} s from the press to the record written`);
  } finally {
    await p.close();
  }
});
