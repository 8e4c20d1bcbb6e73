//! The deployment's units (`deploy/systemd/`), read as systemd reads their keys: every
//! process of hob runs as the unprivileged user `hob`, cannot gain privileges, sees the
//! file system read-only but for hob's own state and the bus (so none can write the machine
//! file in /etc/hob), and only the loop and the watchdog hold a capability, each the ones
//! it needs (README, "Deploying on the machine PC").
#![allow(clippy::unwrap_used)]

use std::collections::BTreeMap;
use std::path::Path;

/// The `[Service]` keys of a unit (a key given twice keeps its last value, as systemd's
/// single-value keys do).
fn service_keys(unit: &str) -> BTreeMap<String, String> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../deploy/systemd")
        .join(unit);
    let text = std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    let mut section = String::new();
    let mut keys = BTreeMap::new();
    for line in text.lines().map(str::trim) {
        if line.starts_with('#') || line.is_empty() {
            continue;
        }
        if line.starts_with('[') {
            section = line.to_string();
        } else if section == "[Service]"
            && let Some((k, v)) = line.split_once('=')
        {
            keys.insert(k.trim().to_string(), v.trim().to_string());
        }
    }
    keys
}

#[test]
fn every_process_runs_unprivileged_and_cannot_write_the_machine_file() {
    let caps = [
        ("hob-rt.service", "CAP_SYS_NICE CAP_IPC_LOCK"),
        ("hob-watchdog.service", "CAP_SYS_NICE"),
        ("hob-logger.service", ""),
        ("hob-hmi.service", ""),
    ];
    for (unit, allowed) in caps {
        let k = service_keys(unit);
        let get = |key: &str| k.get(key).map(String::as_str);
        assert_eq!(get("User"), Some("hob"), "{unit}");
        assert_eq!(get("NoNewPrivileges"), Some("yes"), "{unit}");
        assert_eq!(
            get("ProtectSystem"),
            Some("strict"),
            "{unit}: the file system read-only"
        );
        let writable: Vec<&str> = get("ReadWritePaths").unwrap_or("").split_whitespace().collect();
        assert!(
            writable
                .iter()
                .all(|p| *p == "/tmp" || p.starts_with("/var/lib/hob")),
            "{unit}: writes {writable:?}"
        );
        assert!(!writable.iter().any(|p| p.starts_with("/etc")), "{unit}");
        assert_eq!(
            get("CapabilityBoundingSet"),
            Some(allowed),
            "{unit}: the capabilities it may hold"
        );
        assert_eq!(get("AmbientCapabilities").unwrap_or(""), allowed, "{unit}");
        let exec = get("ExecStart").unwrap_or("");
        assert!(exec.starts_with("/usr/local/bin/hob"), "{unit}: {exec}");
    }
}
