//! The gate on recorded results (fixtures: a quick run measured on the 2-core VM): the
//! shipped limits pass, a breached limit fails exactly its check, impossible limits fail
//! every section, a missing result fails, and the binary's exit status says so.

use hob_bench::gate::{self, Limits};
use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures")
}

fn shipped() -> Limits {
    Limits::load(&root().join("ci/gates.toml")).expect("ci/gates.toml loads")
}

fn failed(checks: &[gate::Check]) -> Vec<String> {
    checks
        .iter()
        .filter(|c| c.pass == Some(false))
        .map(|c| c.name.clone())
        .collect()
}

#[test]
fn recorded_results_pass_the_shipped_limits() {
    let checks = gate::evaluate(&fixtures(), &shipped());
    assert!(gate::passed(&checks), "{}", gate::table(&checks));
    assert!(checks.len() >= 15);
}

#[test]
fn one_breached_limit_fails_exactly_its_check() {
    let mut l = shipped();
    l.step.instructions_per_step = 1000.0;
    let checks = gate::evaluate(&fixtures(), &l);
    let f = failed(&checks);
    assert_eq!(f.len(), 1, "{}", gate::table(&checks));
    assert!(f[0].starts_with("step instructions"), "{f:?}");
    assert!(gate::table(&checks).contains("gate: FAIL (1 of"));
}

#[test]
fn impossible_limits_fail_every_section() {
    let l = Limits::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/impossible-gates.toml"))
        .expect("loads");
    let f = failed(&gate::evaluate(&fixtures(), &l));
    for section in ["loop", "bus", "step", "accuracy", "bus load"] {
        assert!(f.iter().any(|n| n.starts_with(section)), "{section}: {f:?}");
    }
}

#[test]
fn the_loop_under_a_background_load_is_checked_where_it_was_run() {
    let checks = gate::evaluate(&fixtures(), &shipped());
    let loaded: Vec<&str> = checks
        .iter()
        .filter(|c| c.name.starts_with("loop (hackbench) "))
        .map(|c| c.name.as_str())
        .collect();
    assert!(
        loaded.contains(&"loop (hackbench) wake p99 vs cyclictest"),
        "{loaded:?}"
    );
    assert!(
        loaded.contains(&"loop (hackbench) pinned to cyclictest's core"),
        "{loaded:?}"
    );
    // A loaded run that breaches a limit fails the gate even where the unloaded one passes.
    let dir = std::env::temp_dir().join(format!("hob-gate-loaded-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("loop-hackbench")).expect("temp dir");
    for f in [
        "loop.json",
        "bus.json",
        "step.json",
        "accuracy.json",
        "seeds.json",
        "busload.json",
    ] {
        std::fs::copy(fixtures().join(f), dir.join(f)).expect("copy");
    }
    let mut loaded: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(fixtures().join("loop-hackbench/loop.json")).expect("fixture"),
    )
    .expect("json");
    loaded["hob_rt"]["system_allocations_in_cycles"] = 3.into();
    std::fs::write(dir.join("loop-hackbench/loop.json"), loaded.to_string()).expect("write");
    let checks = gate::evaluate(&dir, &shipped());
    assert_eq!(
        failed(&checks),
        vec!["loop (hackbench) system heap allocations in cycles".to_string()]
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_missing_result_fails() {
    let dir = std::env::temp_dir().join(format!("hob-gate-missing-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    for f in [
        "loop.json",
        "bus.json",
        "step.json",
        "accuracy.json",
        "seeds.json",
    ] {
        std::fs::copy(fixtures().join(f), dir.join(f)).expect("copy");
    }
    let checks = gate::evaluate(&dir, &shipped());
    assert_eq!(failed(&checks), vec!["bus load".to_string()]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn unknown_or_missing_limit_keys_are_refused() {
    let text = std::fs::read_to_string(root().join("ci/gates.toml")).expect("reads");
    let typo = text.replace("max_percent", "max_percnt");
    assert!(toml::from_str::<Limits>(&typo).is_err());
}

#[test]
fn binary_exit_status_follows_the_gate() {
    let bin = env!("CARGO_BIN_EXE_hob-bench");
    let run = |limits: PathBuf| {
        Command::new(bin)
            .arg("gate")
            .arg("--results")
            .arg(fixtures())
            .arg("--limits")
            .arg(limits)
            .output()
            .expect("runs")
    };
    let ok = run(root().join("ci/gates.toml"));
    assert_eq!(
        ok.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&ok.stdout)
    );
    let bad = run(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/impossible-gates.toml"));
    assert_eq!(bad.status.code(), Some(1));
    let out = String::from_utf8_lossy(&bad.stdout);
    assert!(out.contains("FAIL") && out.contains("gate: FAIL"), "{out}");
}
