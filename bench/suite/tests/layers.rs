//! The layering of the workspace, checked on `cargo metadata`: which crates may depend on
//! which, which crates may have no I/O dependency, and that the product binaries link no
//! simulator. ARCHITECTURE.md draws the same layers.
#![allow(clippy::unwrap_used)]

use std::collections::{BTreeMap, BTreeSet};

/// Every workspace crate and the workspace crates it may depend on directly (normal
/// dependencies; dev-dependencies are free). Bottom up: wire and pure logic, then the I/O
/// edges, then the processes, then the test bench.
const ALLOWED: &[(&str, &[&str])] = &[
    // The wire: the contract between processes and the machine's vocabulary (message
    // types, every code and its words). Pure, and the bottom: it depends on no crate here.
    ("hob-wire", &[]),
    // Pure: units and gearing, set-up, control core, CANopen, this machine's process image
    // and its CANopen master.
    ("hob-gearing", &[]),
    // Profile disk cutters: their profile, the tooth space they cut, their design.
    ("hob-cutters", &["hob-gearing"]),
    // A gear checker's pitch measurement: its file, read and written.
    ("hob-gear-check", &[]),
    // The machine file and the problems of any TOML file; the set-up (programs, planner)
    // above it.
    ("hob-config", &["hob-gearing"]),
    ("hob-setup", &["hob-gearing", "hob-cutters", "hob-config"]),
    ("hob-control", &["hob-gearing", "hob-setup", "hob-wire"]),
    ("hob-canopen", &["hob-wire"]),
    (
        "hob-process-image",
        &["hob-canopen", "hob-gearing", "hob-config", "hob-wire"],
    ),
    ("hob-master", &["hob-canopen", "hob-process-image", "hob-control"]),
    // I/O edges: the shared-memory services and the gateway's socket, the CAN transports
    // (and the clock start-up waits on), the OS real-time helpers, files on disk.
    ("hob-ipc", &["hob-wire"]),
    ("hob-can-transport", &["hob-canopen", "hob-ipc"]),
    ("hob-rt-os", &[]),
    ("hob-store", &["hob-gearing", "hob-setup", "hob-rt-os"]),
    // Processes (the product).
    (
        "hob-service",
        &[
            "hob-gearing",
            "hob-setup",
            "hob-control",
            "hob-canopen",
            "hob-process-image",
            "hob-master",
            "hob-can-transport",
            "hob-rt-os",
            "hob-store",
            "hob-ipc",
        ],
    ),
    (
        "hob-logger",
        &[
            "hob-gearing",
            "hob-gear-check",
            "hob-ipc",
            "hob-rt-os",
            "hob-store",
        ],
    ),
    (
        "hob-watchdog",
        &[
            "hob-canopen",
            "hob-can-transport",
            "hob-config",
            "hob-process-image",
            "hob-ipc",
            "hob-rt-os",
        ],
    ),
    // The commissioning procedures (the CLI's and the HMI's): the loop's commands and
    // streams, the delay's fit, the machine file's edit and its records; no control core.
    (
        "hob-commission",
        &["hob-ipc", "hob-logger", "hob-setup", "hob-store"],
    ),
    // The gateway for the frontends of other users: forwards the wire, no control core.
    ("hob-gateway", &["hob-ipc", "hob-rt-os"]),
    (
        "hob-cli",
        &[
            "hob-commission",
            "hob-gearing",
            "hob-cutters",
            // `hob compensate`: the checker's file and its decomposition.
            "hob-gear-check",
            "hob-setup",
            "hob-control",
            "hob-canopen",
            "hob-process-image",
            "hob-master",
            "hob-can-transport",
            "hob-ipc",
            "hob-logger",
            "hob-store",
        ],
    ),
    // The touch HMI: no control core (codes through hob-ipc's codec, signals through
    // hob-setup), no CAN.
    (
        "hob-hmi",
        &[
            "hob-commission",
            "hob-gearing",
            "hob-setup",
            "hob-ipc",
            "hob-logger",
            "hob-rt-os",
            "hob-store",
        ],
    ),
    // The test bench: the simulated machine, the virtual machine on the bus, the commands
    // that need them, the benchmarks.
    (
        "hob-plant",
        &[
            "hob-cutters",
            "hob-gear-check",
            "hob-gearing",
            "hob-setup",
            "hob-control",
            "hob-ipc",
            "hob-logger",
            "hob-store",
        ],
    ),
    (
        "hob-virtual-machine",
        &[
            "hob-canopen",
            "hob-can-transport",
            "hob-control",
            // hob-loop-double: a stand-in for the loop's ports (the watchdog's tests).
            "hob-ipc",
            // The truth it writes beside a recording is in the logger's format.
            "hob-logger",
            "hob-master",
            "hob-plant",
            "hob-process-image",
            "hob-rt-os",
            "hob-setup",
            "hob-store",
        ],
    ),
    (
        "hob-lab",
        &[
            "hob-cli",
            "hob-can-transport",
            "hob-control",
            "hob-ipc",
            "hob-logger",
            "hob-master",
            "hob-plant",
            "hob-process-image",
            // `hob demo --hmi` stops its processes in order at Ctrl-C or SIGTERM.
            "hob-rt-os",
            "hob-setup",
            "hob-store",
            "hob-virtual-machine",
        ],
    ),
    (
        "hob-bench",
        &[
            "hob-can-transport",
            "hob-control",
            "hob-gearing",
            "hob-ipc",
            "hob-plant",
            "hob-process-image",
            "hob-rt-os",
            "hob-service",
            "hob-setup",
            "hob-store",
            "hob-virtual-machine",
        ],
    ),
    // The multi-process tests talk to the binaries as a user does: no project crate.
    ("hob-system-tests", &[]),
    // The fuzz targets' properties: the decoders of outside data they drive (and hob-rt's
    // counting allocator, to hold the cyclic exchange to no allocation).
    (
        "hob-fuzz-harness",
        &[
            "hob-canopen",
            "hob-control",
            "hob-hmi",
            "hob-ipc",
            "hob-logger",
            "hob-master",
            "hob-process-image",
            "hob-rt-os",
            "hob-service",
            "hob-setup",
        ],
    ),
];

/// What a crate must not link, directly or through any other (transitive closures): the
/// independent watchdog, the frontends that add no control logic, the contract.
const MUST_NOT_LINK: &[(&str, &[&str])] = &[
    // The safety watchdog is a second channel: it must not share the control core's faults
    // nor the set-up's code (it needs the machine file and its bus plan only).
    (
        "hob-watchdog",
        &[
            "hob-control",
            "hob-master",
            "hob-service",
            "hob-setup",
            "hob-cutters",
            "hob-store",
        ],
    ),
    ("hob-logger", &["hob-control", "hob-setup", "hob-master"]),
    (
        "hob-hmi",
        &[
            "hob-control",
            "hob-master",
            "hob-process-image",
            "hob-can-transport",
        ],
    ),
    ("hob-gateway", &["hob-control", "hob-setup", "hob-master"]),
    ("hob-commission", &["hob-control", "hob-master"]),
    // CANopen knows no control core and no machine.
    ("hob-canopen", &["hob-control", "hob-setup", "hob-process-image"]),
    // The bus plan borrows nothing from the control core.
    ("hob-process-image", &["hob-control", "hob-master", "hob-setup"]),
    // The CAN transports carry frames: no machine, no control core.
    (
        "hob-can-transport",
        &["hob-control", "hob-setup", "hob-process-image"],
    ),
];

/// Crates without I/O: the only outside crates they may use (normal dependencies).
const PURE: &[(&str, &[&str])] = &[
    // iceoryx2's marker trait for shared memory and its derive: no I/O (the ports are
    // hob-ipc's).
    (
        "hob-wire",
        &[
            "serde",
            "postcard",
            "iceoryx2-bb-elementary-traits",
            "iceoryx2-bb-derive-macros",
        ],
    ),
    ("hob-gearing", &["serde"]),
    ("hob-cutters", &["serde"]),
    ("hob-config", &["serde", "toml"]),
    ("hob-setup", &["serde", "toml"]),
    ("hob-control", &["serde", "nalgebra", "postcard"]),
    ("hob-canopen", &[]),
    ("hob-process-image", &[]),
    ("hob-master", &[]),
];

/// What a pure crate's source must not call: a clock, a sleep, a file, a socket, a
/// process (checked in `src/`, tests left out; the edges do these).
const IO_CALLS: &[&str] = &[
    "std::fs",
    "std::net",
    "std::os::unix::net",
    "std::process",
    "Instant::now",
    "SystemTime",
    "thread::sleep",
    "File::open",
    "File::create",
];

/// The I/O edges that may use outside crates only from a short list (files on disk need
/// nothing but std, serde and TOML: no new heavy dependency).
const EDGE_OUTSIDE: &[(&str, &[&str])] = &[("hob-store", &["serde", "toml"])];

/// What the product links: never the simulated machine, the virtual machine or the lab.
const PRODUCT: &[&str] = &[
    "hob-service",
    "hob-logger",
    "hob-watchdog",
    "hob-gateway",
    "hob-cli",
    "hob-hmi",
];
const SIMULATORS: &[&str] = &["hob-plant", "hob-virtual-machine", "hob-lab", "hob-bench"];

struct Workspace {
    /// Workspace crate -> its workspace dependencies (normal).
    internal: BTreeMap<String, BTreeSet<String>>,
    /// Workspace crate -> its outside dependencies (normal).
    external: BTreeMap<String, BTreeSet<String>>,
    /// Workspace crate -> its source files under `src/` without their tests (path, code
    /// with comments removed).
    sources: BTreeMap<String, Vec<(String, String)>>,
}

/// The code of a source file as the I/O check reads it: comments removed, and each item
/// under `#[cfg(test)]` left out (a test module may use the clock): a `mod x;` line, or a
/// block to its matching brace.
fn code_of(text: &str) -> String {
    let mut out = String::new();
    let mut lines = text.lines();
    while let Some(line) = lines.next() {
        let code = line.split("//").next().unwrap_or("");
        if !code.trim_start().starts_with("#[cfg(test)]") {
            out.push_str(code);
            out.push('\n');
            continue;
        }
        // Skip the item the attribute applies to.
        let mut depth = 0i32;
        let mut opened = false;
        for item in lines.by_ref() {
            let item = item.split("//").next().unwrap_or("");
            depth += item.matches('{').count() as i32 - item.matches('}').count() as i32;
            opened |= item.contains('{');
            if (opened && depth <= 0) || (!opened && item.trim_end().ends_with(';')) {
                break;
            }
        }
    }
    out
}

/// The source files of a crate's `src/`, tests left out (files named `tests.rs` or in a
/// `tests` folder).
fn sources_of(src: &std::path::Path) -> Vec<(String, String)> {
    rust_files(src)
        .into_iter()
        .filter(|path| {
            let rel = path.strip_prefix(src).unwrap_or(path);
            !rel.iter().any(|c| c == "tests" || c == "tests.rs")
        })
        .map(|path| {
            let text = std::fs::read_to_string(&path).unwrap();
            (path.display().to_string(), code_of(&text))
        })
        .collect()
}

fn workspace() -> Workspace {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = std::process::Command::new(cargo)
        .args(["metadata", "--format-version", "1", "--no-deps", "--offline"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cargo metadata");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let packages = v["packages"].as_array().unwrap();
    let names: BTreeSet<String> = packages
        .iter()
        .map(|p| p["name"].as_str().unwrap().to_string())
        .collect();
    let mut ws = Workspace {
        internal: BTreeMap::new(),
        external: BTreeMap::new(),
        sources: BTreeMap::new(),
    };
    for p in packages {
        let name = p["name"].as_str().unwrap().to_string();
        let (mut int, mut ext) = (BTreeSet::new(), BTreeSet::new());
        for d in p["dependencies"].as_array().unwrap() {
            if !d["kind"].is_null() {
                continue; // dev and build dependencies
            }
            let dep = d["name"].as_str().unwrap().to_string();
            if names.contains(&dep) {
                int.insert(dep);
            } else {
                ext.insert(dep);
            }
        }
        let manifest = std::path::PathBuf::from(p["manifest_path"].as_str().unwrap());
        let src = manifest.parent().unwrap().join("src");
        ws.sources.insert(name.clone(), sources_of(&src));
        ws.internal.insert(name.clone(), int);
        ws.external.insert(name, ext);
    }
    ws
}

fn closure(ws: &Workspace, root: &str) -> BTreeSet<String> {
    let mut seen = BTreeSet::new();
    let mut todo = vec![root.to_string()];
    while let Some(c) = todo.pop() {
        for d in ws.internal.get(&c).into_iter().flatten() {
            if seen.insert(d.clone()) {
                todo.push(d.clone());
            }
        }
    }
    seen
}

/// The rule breaches (empty when the workspace keeps its layers).
fn breaches(ws: &Workspace) -> Vec<String> {
    let mut out = Vec::new();
    let allowed: BTreeMap<&str, &[&str]> = ALLOWED.iter().copied().collect();
    for (name, deps) in &ws.internal {
        let Some(ok) = allowed.get(name.as_str()) else {
            out.push(format!(
                "{name}: a crate the layer rules do not know (add it to ALLOWED)"
            ));
            continue;
        };
        for d in deps {
            if !ok.contains(&d.as_str()) {
                out.push(format!("{name} depends on {d}, which its layer may not use"));
            }
        }
    }
    for (name, ok) in PURE {
        for d in closure(ws, name).iter().chain([name.to_string()].iter()) {
            for e in ws.external.get(d).into_iter().flatten() {
                let allowed_here = PURE
                    .iter()
                    .find(|(n, _)| n == d)
                    .is_some_and(|(_, list)| list.contains(&e.as_str()));
                if !allowed_here || (d == name && !ok.contains(&e.as_str())) {
                    out.push(format!("{name} must have no I/O dependency, but {d} uses {e}"));
                }
            }
            if !PURE.iter().any(|(n, _)| n == d) {
                out.push(format!("{name} is pure but depends on {d}, which is not"));
            }
        }
    }
    for (name, _) in PURE {
        for (path, code) in ws.sources.get(*name).into_iter().flatten() {
            for call in IO_CALLS {
                if code.contains(call) {
                    out.push(format!("{name} is pure but its source calls {call} ({path})"));
                }
            }
        }
    }
    for (name, never) in MUST_NOT_LINK {
        let linked = closure(ws, name);
        for n in *never {
            if linked.contains(*n) {
                let via: Vec<&String> = ws.internal[*name]
                    .iter()
                    .filter(|d| d.as_str() == *n || closure(ws, d).contains(*n))
                    .collect();
                out.push(format!("{name} links {n} (through {via:?})"));
            }
        }
    }
    for (name, ok) in EDGE_OUTSIDE {
        for e in ws.external.get(*name).into_iter().flatten() {
            if !ok.contains(&e.as_str()) {
                out.push(format!(
                    "{name} may use only {ok:?} outside the workspace, but uses {e}"
                ));
            }
        }
    }
    for p in PRODUCT {
        for d in closure(ws, p) {
            if SIMULATORS.contains(&d.as_str()) {
                out.push(format!("the product crate {p} links {d}"));
            }
        }
    }
    out
}

#[test]
fn the_workspace_keeps_its_layers() {
    let ws = workspace();
    let b = breaches(&ws);
    assert!(b.is_empty(), "layer rules broken:\n{}", b.join("\n"));
    // The rules know every crate, and every crate of the rules exists.
    for (name, _) in ALLOWED {
        assert!(
            ws.internal.contains_key(*name),
            "{name} is in the rules but not in the workspace"
        );
    }
}

#[test]
fn canopen_does_not_import_the_control_core() {
    let ws = workspace();
    // Only the wire's words (EMCY texts, NMT and CiA 402 states, send errors).
    let c = closure(&ws, "hob-canopen");
    assert!(c.iter().all(|d| d == "hob-wire"), "hob-canopen depends on {c:?}");
}

#[test]
fn the_contract_between_processes_is_the_bottom_layer() {
    // No control core, set-up, gearing or process image below the wire: every frontend
    // decodes a code without linking them, and the control core uses its vocabulary.
    let ws = workspace();
    let c = closure(&ws, "hob-wire");
    assert!(c.is_empty(), "hob-wire depends on {c:?}");
    let c = closure(&ws, "hob-ipc");
    assert_eq!(
        c,
        BTreeSet::from(["hob-wire".to_string()]),
        "hob-ipc depends on {c:?}"
    );
    for user in ["hob-control", "hob-canopen", "hob-ipc"] {
        assert!(
            ws.internal[user].contains("hob-wire"),
            "{user} does not use the wire's vocabulary"
        );
    }
}

#[test]
fn a_breach_of_each_kind_is_reported() {
    // The check must be able to fail: the same rules on a workspace with one breach each.
    let mut ws = workspace();
    ws.internal
        .get_mut("hob-canopen")
        .unwrap()
        .insert("hob-control".into());
    ws.external.get_mut("hob-control").unwrap().insert("nix".into());
    ws.internal.get_mut("hob-cli").unwrap().insert("hob-plant".into());
    ws.internal.insert("hob-new".into(), BTreeSet::new());
    ws.external
        .get_mut("hob-store")
        .unwrap()
        .insert("rusqlite".into());
    ws.internal
        .get_mut("hob-wire")
        .unwrap()
        .insert("hob-control".into());
    // Through another crate: the bus plan borrowing from the control core again makes
    // the watchdog link it.
    ws.internal
        .get_mut("hob-process-image")
        .unwrap()
        .insert("hob-control".into());
    // A pure crate that reads the clock, sleeps, or opens a socket.
    ws.sources.get_mut("hob-control").unwrap().push((
        "rt-core/control/src/late.rs".into(),
        code_of("fn late() -> bool { std::time::Instant::now() > t0 } // std::fs in a comment is fine\n"),
    ));
    ws.sources.get_mut("hob-wire").unwrap().push((
        "ipc/wire/src/peer.rs".into(),
        code_of(
            "#[cfg(test)]\nmod tests {\n    fn t() { std::fs::read(p); }\n}\nfn peer() { let s = std::os::unix::net::UnixStream::connect(p); }\n#[cfg(test)]\nmod more;\nfn later() { std::thread::sleep(d); }\n",
        ),
    ));
    let b = breaches(&ws).join("\n");
    assert!(
        !b.contains("std::fs"),
        "a comment or a test counted as a call:\n{b}"
    );
    for needle in [
        "hob-canopen depends on hob-control",
        "hob-control must have no I/O dependency, but hob-control uses nix",
        "hob-process-image must have no I/O dependency, but hob-control uses nix",
        "hob-cli depends on hob-plant",
        "the product crate hob-cli links hob-plant",
        "hob-new: a crate the layer rules do not know",
        "hob-wire depends on hob-control",
        "hob-process-image depends on hob-control",
        "hob-watchdog links hob-control (through [",
        "hob-process-image links hob-control",
        "hob-control is pure but its source calls Instant::now (rt-core/control/src/late.rs)",
        "hob-wire is pure but its source calls std::os::unix::net (ipc/wire/src/peer.rs)",
        "hob-wire is pure but its source calls thread::sleep (ipc/wire/src/peer.rs)",
        "hob-store may use only [\"serde\", \"toml\"] outside the workspace, but uses rusqlite",
    ] {
        assert!(b.contains(needle), "{needle:?} not reported in:\n{b}");
    }
}

/// The functions of a source text longer than `limit` lines (from the `fn` line to its
/// closing brace, counted by matching braces outside strings, chars and comments): name
/// and length.
fn long_functions(code: &str, limit: usize) -> Vec<(String, usize)> {
    let lines: Vec<&str> = code.lines().collect();
    let mut out = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        let t = line.trim_start();
        let head = t
            .trim_start_matches("pub(crate) ")
            .trim_start_matches("pub(super) ")
            .trim_start_matches("pub ")
            .trim_start_matches("const ")
            .trim_start_matches("async ")
            .trim_start_matches("unsafe ");
        let Some(rest) = head.strip_prefix("fn ") else {
            continue;
        };
        let name: String = rest
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        let (mut depth, mut opened) = (0i64, false);
        for (j, l) in lines[i..].iter().enumerate() {
            let l = l.split("//").next().unwrap_or("");
            let mut in_str = false;
            let mut prev = ' ';
            for c in l.chars() {
                match c {
                    '"' if prev != '\\' && prev != '\'' => in_str = !in_str,
                    '{' if !in_str => {
                        depth += 1;
                        opened = true;
                    }
                    '}' if !in_str => depth -= 1,
                    _ => {}
                }
                prev = c;
            }
            if !opened && l.contains(';') {
                break; // a declaration without a body
            }
            if opened && depth <= 0 {
                if j + 1 > limit {
                    out.push((name.clone(), j + 1));
                }
                break;
            }
        }
    }
    out
}

/// Every `.rs` file under `dir` (all of it, tests included).
fn rust_files(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        let Ok(entries) = std::fs::read_dir(&d) else {
            continue;
        };
        for e in entries.flatten() {
            let p = e.path();
            let name = e.file_name().to_string_lossy().to_string();
            if p.is_dir() && name != "target" && name != "node_modules" {
                todo.push(p);
            } else if name.ends_with(".rs") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

#[test]
fn no_function_in_the_product_is_over_100_lines() {
    // rt-core/, ipc/ and frontends/, tests included: a function a newcomer can read whole.
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut long = Vec::new();
    let mut files = 0;
    for top in ["rt-core", "ipc", "frontends"] {
        for path in rust_files(&root.join(top)) {
            files += 1;
            let text = std::fs::read_to_string(&path).unwrap();
            for (name, n) in long_functions(&text, 100) {
                long.push(format!("{}: {name} ({n} lines)", path.display()));
            }
        }
    }
    assert!(files > 100, "only {files} files read");
    assert!(long.is_empty(), "functions over 100 lines:\n{}", long.join("\n"));
}

#[test]
fn a_long_function_is_found() {
    let body: String = (0..101).map(|i| format!("    let _x{i} = \"{{\";\n")).collect();
    let code = format!("pub fn short() {{\n}}\n\nfn long() {{\n{body}}}\n\nfn decl();\n");
    assert_eq!(long_functions(&code, 100), [("long".to_string(), 103)]);
    assert!(long_functions(&code, 103).is_empty());
}

/// The modules of one crate's `src/` and the sibling modules each names (`crate::m` or, in
/// a top-level file, `super::m`), comments and test items left out. Module `m` is the
/// first component under `src/` (`src/m.rs` or `src/m/...`).
fn module_imports(src: &std::path::Path) -> BTreeMap<String, BTreeSet<String>> {
    let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for path in rust_files(src) {
        let rel = path.strip_prefix(src).unwrap();
        let parts: Vec<String> = rel
            .iter()
            .map(|p| p.to_string_lossy().trim_end_matches(".rs").to_string())
            .collect();
        if parts[0] == "bin" || parts.iter().any(|p| p == "tests") {
            continue;
        }
        let top = match parts[0].as_str() {
            "lib" | "main" | "mod" => continue,
            m => m.to_string(),
        };
        let code = code_of(&std::fs::read_to_string(&path).unwrap());
        let mut names = BTreeSet::new();
        let mut prefixes = vec!["crate::"];
        if parts.len() == 1 {
            prefixes.push("super::");
        }
        for prefix in prefixes {
            for (i, _) in code.match_indices(prefix) {
                let name: String = code[i + prefix.len()..]
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_')
                    .collect();
                if name != top {
                    names.insert(name);
                }
            }
        }
        g.entry(top).or_default().extend(names);
    }
    let modules: BTreeSet<String> = g.keys().cloned().collect();
    for deps in g.values_mut() {
        deps.retain(|d| modules.contains(d));
    }
    g
}

/// The modules that reach themselves through the others (empty: no circle).
fn modules_in_circles(g: &BTreeMap<String, BTreeSet<String>>) -> BTreeSet<String> {
    let reach = |from: &String| {
        let mut seen = BTreeSet::new();
        let mut todo: Vec<&String> = g[from].iter().collect();
        while let Some(m) = todo.pop() {
            if seen.insert(m.clone()) {
                todo.extend(g.get(m).into_iter().flatten());
            }
        }
        seen
    };
    g.keys().filter(|m| reach(m).contains(*m)).cloned().collect()
}

#[test]
fn no_crate_has_a_circle_of_modules() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut circles = Vec::new();
    let mut crates = 0;
    for top in ["rt-core", "ipc", "frontends", "bench"] {
        for dir in std::fs::read_dir(root.join(top)).unwrap().flatten() {
            let src = dir.path().join("src");
            if !src.is_dir() {
                continue;
            }
            crates += 1;
            let c = modules_in_circles(&module_imports(&src));
            if !c.is_empty() {
                circles.push(format!("{}: {c:?}", dir.path().display()));
            }
        }
    }
    assert!(crates > 15, "only {crates} crates read");
    assert!(
        circles.is_empty(),
        "modules that import each other in a circle:\n{}",
        circles.join("\n")
    );
}

#[test]
fn a_circle_of_modules_is_found() {
    let g: BTreeMap<String, BTreeSet<String>> = [
        ("events", vec!["sequencer"]),
        ("sequencer", vec!["jog"]),
        ("jog", vec!["events", "fault"]),
        ("fault", vec![]),
    ]
    .into_iter()
    .map(|(m, d)| (m.to_string(), d.into_iter().map(String::from).collect()))
    .collect();
    let c: Vec<String> = modules_in_circles(&g).into_iter().collect();
    assert_eq!(c, ["events", "jog", "sequencer"]);
}
