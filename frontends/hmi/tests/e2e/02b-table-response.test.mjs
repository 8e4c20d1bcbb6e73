// Commissioning from DIAGNOSTICS: the table's frequency response through the worm (the TABLE
// RESPONSE key, the procedure of `hob commission response`, run by the HMI server with the
// held key as its enable), through a builder's page in Chromium against hob-sim. The suite's
// machine file has the shipped [table.drive_model] and hob-sim's drives report their gains at
// boot (hob-rt's NODES answer carries them). Held to the end, the table's target swings at
// 32 frequencies while the table creeps +, the Bode plot (the server's SVG: the measured
// points, the fitted model's lines, the mesh's frequencies) shows with the fit and its
// margins and the diff with `[commissioning.table_drive_gains]`, and WRITE writes that record,
// the old file kept (the test puts the file back as it was for the later tests).
//
// It runs here, after the backlash (02-table-backlash, which needs the table where it stood
// at power-on: this one creeps it some 50 deg) and before the cut (03), which starts from
// wherever the table stands.
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

test("the table response's key held to the end: the Bode plot, the margins, the gains proposed and written", async () => {
  const p = await ctx.newPage();
  try {
    await p.goto(`${builder.url}#diagnostics`);
    await p.locator('[data-testid="commission-response-hold"]').waitFor({ timeout: 20000 });
    const card = await p.locator('[data-testid="commission-response"]').innerText();
    assert.match(card, /at 16 frequencies from 2 to 250 Hz, then as many again about the deepest dip, the table creeping \+ at 36 deg\/min meanwhile \(about \d+ s, \d+ deg of the table\)/);
    assert.equal(await p.locator('[data-testid="commission-response-model"]').count(), 0, "the card says the machine file has no [table.drive_model]");
    const file = readFileSync(machine, "utf8");
    assert.ok(file.includes("\n[table.drive_model]\n"), "the suite's machine file has no [table.drive_model]");
    const s0 = status();
    assert.equal(s0.state, "idle", "the machine is not idle before the test");
    const st = p.locator('[data-testid="commission-response-state"]');
    const t0 = Date.now();
    const hold = await touchHold(p, '[data-testid="commission-response-hold"]', 0);
    // A refusal or a stop before the swing ends the wait with its words.
    await waitFor("the table's target swinging", async () => {
      if (["stopped", "refused"].includes(await st.getAttribute("data-state"))) throw new Error(await st.innerText());
      return /swinging the table at [\d.]+ Hz/.test(await st.innerText());
    }, 15000, 50).catch(async (e) => { await hold.lift(); throw e; });
    // The loop's truth, not the page's: the table swings (a jog of the loop's).
    const swinging = await waitFor("the loop swinging the table", () => { const s = status(); return s.state === "jog" ? s : null; }, 5000, 100);
    await waitFor("the proposal", async () => ["proposal", "stopped", "refused"].includes(await st.getAttribute("data-state")), 240000, 200);
    const held = await hold.lift();
    const said = await st.innerText();
    assert.equal(await st.getAttribute("data-state"), "proposal", said);
    const m = said.match(/^(\d+) points; the mesh's anti-resonance ([\d.]+) Hz, resonance ([\d.]+) Hz; the present tuning (stable|UNSTABLE).*; proposed kp ([\d.]+) Nm s\/rad, Ti ([\d.]+) ms, kv ([\d.]+) 1\/s with cascade GM ([\d.]+) dB, PM ([\d.]+) deg, as \[commissioning\.table_drive_gains\]/);
    assert.ok(m, said);
    const [points, kp, gm, pm] = [Number(m[1]), Number(m[5]), Number(m[8]), Number(m[9])];
    assert.equal(points, 32, said);
    // The procedure's own goal (GM 6 dB, PM 40 deg on the cascade), as the page says it.
    assert.ok(gm >= 5.9 && pm >= 39.5, `the proposed margins: GM ${gm} dB, PM ${pm} deg`);
    // The Bode plot on the page: one SVG, a point on each panel per frequency, the model's two
    // lines, the mesh's frequencies marked.
    const bode = p.locator('[data-testid="commission-bode"] svg');
    assert.equal(await bode.count(), 1, "no Bode plot on the page");
    assert.ok(await bode.isVisible(), "the Bode plot is not shown");
    assert.equal(await bode.locator("circle").count(), 2 * points, "not a point per frequency on each panel");
    assert.equal(await bode.locator("polyline").count(), 2, "not the model's magnitude and phase");
    const plotted = await bode.textContent();
    assert.ok(plotted.includes(`anti-resonance ${m[2]} Hz`) && plotted.includes("dB") && plotted.includes("deg"), plotted);
    const box = await bode.boundingBox();
    assert.ok(box.width >= 500 && box.width <= 700 && box.height >= 360 && box.height <= 520, `the plot is ${box.width} x ${box.height} px`);
    // The fit and its margins in words beside it.
    const report = await p.locator('[data-testid="commission-report"]').innerText();
    assert.match(report, /table frequency response: 32 points from 2\.0 to 250\.0 Hz/);
    assert.match(report, /the drive's present gains \(kp [\d.]+ Nm s\/rad, Ti [\d.]+ ms, kv [\d.]+ 1\/s\): (stable: velocity loop GM [\d.]+ dB at \d+ Hz, PM [\d.]+ deg|UNSTABLE)/);
    assert.ok(report.includes(`cascade GM ${m[8]} dB, PM ${m[9]} deg`), report);
    const diff = await p.locator('[data-testid="commission-diff"]').innerText();
    assert.match(diff, /\+ *\d+ +\[commissioning\.table_drive_gains\]/);
    assert.match(diff, /\+ *\d+ +velocity_kp_nm_s_per_rad = [\d.]+/);
    assert.equal(await p.locator('[data-testid="commission-proposal-of"]').getAttribute("data-procedure"), "response");
    assert.equal(await p.locator('[data-testid="commission-write"]').isDisabled(), false, "WRITE is dark on a builder's panel");
    assert.equal(readFileSync(machine, "utf8"), file, "the machine file changed before WRITE");
    await waitFor("the machine idle", () => status().state === "idle", 5000, 100);
    const s1 = status();
    // WRITE, the plot, the fit and the start of the diff on the screen together.
    // (Only the page's scrolling pane scrolls: scrollIntoView would scroll the panel itself.)
    await p.locator('[data-testid="commission-write"]').evaluate((el) => {
      const row = el.closest(".row");
      let pane = row.parentElement;
      while (pane && !(pane.scrollHeight > pane.clientHeight && getComputedStyle(pane).overflowY !== "visible")) pane = pane.parentElement;
      if (pane) pane.scrollTop += row.getBoundingClientRect().top - pane.getBoundingClientRect().top - 8;
    });
    await shot(p, "diagnostics-commissioning-response");
    const before = baks();
    await p.locator('[data-testid="commission-write"]').tap();
    await waitFor("written", async () => (await st.getAttribute("data-state")) === "written", 10000, 100);
    assert.match(await st.innerText(), /restart hob-rt/);
    const written = readFileSync(machine, "utf8");
    const record = written.slice(written.indexOf("[commissioning.table_drive_gains]"));
    assert.ok(record.startsWith("[commissioning.table_drive_gains]"), "no record written");
    const kpWritten = Number(record.match(/\nvelocity_kp_nm_s_per_rad = ([\d.]+)\n/)[1]);
    assert.ok(Math.abs(kpWritten - kp) <= 0.0005 + 1e-9, `written kp ${kpWritten}, proposed ${kp}`);
    assert.match(record, /\nprevious_velocity_kp_nm_s_per_rad = [\d.]+\n/);
    const kept = baks().filter((f) => !before.includes(f));
    assert.equal(kept.length, 1, `kept: ${kept}`);
    assert.equal(readFileSync(join(dirname(machine), kept[0]), "utf8"), file, "the kept file is not the old one");
    // The later tests' machine file as it was (06 counts the files kept by its own WRITE).
    writeFileSync(machine, file);
    unlinkSync(join(dirname(machine), kept[0]));
    console.log(`response: ${said}; held ${held} ms (the loop in ${swinging.state}); the table crept from ${s0.table_deg.toFixed(1)} to ${s1.table_deg.toFixed(1)} deg; ${((Date.now() - t0) / 1000).toFixed(1)} s from the press to the record written`);
  } finally {
    await p.close();
  }
});
