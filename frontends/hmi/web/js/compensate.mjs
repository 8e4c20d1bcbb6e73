// COMPENSATE (issue 34): measure the first gear, correct the second. The operator picks the
// gear checker's files in the measurements folder (one per height), the program the gear was
// cut with and the cut in the log; PREVIEW runs `hob compensate` on the server and shows what
// it says (its findings, the file it would write or the diff against the current one, its
// plot) or its refusal word for word; WRITE (a setter's work) writes what PREVIEW showed.
// The page computes nothing: the server runs the CLI, which does.
import { useState, useEffect } from "preact/hooks";
import { html, t, allows } from "./ui.mjs";
import { api } from "./conn.mjs";

const when = (s) => new Date(s * 1000).toISOString().slice(0, 16).replace("T", " ");

/** The cut to match the measurements to: each finished cycle the HMI saw (as the cut report
 *  takes it), newest first, or the log's newest run of hob-rt whole. */
function cutLabel(c) {
  return c ? t("cycles {0} .. {1}", c[0], c[1]) : t("the whole log (the newest run of hob-rt)");
}

function Result({ r }) {
  if (!r) return html`<p class="hint" data-testid="compensate-result" data-state="">${t("nothing previewed since the page opened")}</p>`;
  const bad = r.state === "refused" || r.state === "failed";
  return html`<div data-testid="compensate-result" data-state=${r.state}>
    ${bad ? html`<p class="warn">${r.state === "refused" ? t("REFUSED, nothing written:") : t("FAILED:")}</p>` : ""}
    ${r.state === "written" ? html`<p class="ok" data-testid="compensate-restart"><b>${t("Written. Restart hob-rt for the loop to load it; then PITCH COMP ON.")}</b></p>` : ""}
    ${r.svg ? html`<div class="compensate-plot" data-testid="compensate-plot" dangerouslySetInnerHTML=${{ __html: r.svg }}></div>` : ""}
    <pre class=${`small ${bad ? "bad" : ""}`} style="white-space: pre-wrap" data-testid="compensate-text">${r.text}</pre></div>`;
}

export function Compensate({ conn, program }) {
  const [info, setInfo] = useState(null);
  const [programs, setPrograms] = useState([]);
  const [picked, setPicked] = useState([]);
  const [prog, setProg] = useState(program || "");
  const [cut, setCut] = useState(0);
  const [result, setResult] = useState(null);
  const [busy, setBusy] = useState(false);
  const load = async () => {
    const i = await api("GET", "/api/compensate");
    setInfo(i);
    const p = await api("GET", "/api/programs");
    const names = p.ok ? p.entries.filter((e) => e.valid).map((e) => e.name) : [];
    setPrograms(names);
    setProg((now) => now || i.loaded || names[0] || "");
  };
  useEffect(() => { load(); }, []);
  if (!info) return html`<section class="card"><h2>${t("Pitch compensation")}</h2><p>${t("reading...")}</p></section>`;
  const cuts = [...(info.cuts || []), null];
  const toggle = (name) => setPicked(picked.includes(name) ? picked.filter((n) => n !== name) : [...picked, name]);
  const run = async (path, body) => {
    setBusy(true);
    const r = await api("POST", path, body);
    setBusy(false);
    setResult({ state: r.state || (r.ok ? "preview" : "refused"), text: r.text || r.refused || "", svg: r.svg });
    setInfo(await api("GET", "/api/compensate"));
  };
  const preview = () => run("/api/compensate/preview", { program: prog, measurements: picked, cycles: cuts[cut] });
  const write = () => run("/api/compensate/write");
  const mayWrite = allows(conn, "compensate");
  return html`<section class="grid2">
    <div class="card" data-testid="compensate"><h2>${t("Pitch compensation")}</h2>
      <p class="hint">${t("The gear checker's files of the first gear (one per face height), matched to the cut's own log: the table's repeatable error and the hob's once-per-turn term are what a compensation removes; the rest stays. Written for the table's worm set {0}, the old one kept.", info.worm_set || "-")}</p>
      <h3>${t("Measurements")}</h3>
      ${info.files_refused ? html`<p class="warn" data-testid="compensate-no-folder">${info.files_refused}</p>`
        : info.files.length === 0 ? html`<p class="hint" data-testid="compensate-no-files">${t("no checker's file (.csv) in {0}", info.dir)}</p>`
        : html`<p class="small hint">${info.dir}</p><div class="row" data-testid="compensate-files">${info.files.map((f) => html`
          <button class=${`key small ${picked.includes(f.name) ? "on" : ""}`} data-file=${f.name} onClick=${() => toggle(f.name)}>${f.name}<div class="small">${when(f.modified_unix_s)}</div></button>`)}</div>`}
      <h3>${t("The cut")}</h3>
      <div class="row"><label>${t("program")} <select data-testid="compensate-program" value=${prog} onChange=${(e) => setProg(e.currentTarget.value)}>
        ${programs.map((n) => html`<option value=${n}>${n}</option>`)}</select></label></div>
      <div class="row"><label>${t("cut")} <select data-testid="compensate-cut" value=${cut} onChange=${(e) => setCut(Number(e.currentTarget.value))}>
        ${cuts.map((c, i) => html`<option value=${i}>${cutLabel(c)}</option>`)}</select></label>
        ${info.log_dir ? "" : html`<span class="warn">${t("hob-hmi has no --log-dir: no log of the cut")}</span>`}</div>
      <div class="row">
        <button class="key" data-testid="compensate-preview" disabled=${busy || !picked.length || !prog} onClick=${preview}>${t("PREVIEW")}</button>
        <button class="key primary" data-testid="compensate-write" disabled=${busy || !info.held || !mayWrite} onClick=${write}>${t("WRITE")}</button>
        ${busy ? html`<span class="hint">${t("hob compensate is running...")}</span>` : ""}
        ${mayWrite ? "" : html`<span class="hint" data-testid="compensate-level">${t("WRITE: a setter's work")}</span>`}</div>
    </div>
    <div class="card"><h2>${t("What hob compensate says")}</h2><${Result} r=${result} /></div>
  </section>`;
}
