//! The deployment's units (`deploy/systemd/`), read as systemd reads their keys: every
//! process of the bus runs as the unprivileged user `hob`, the HMI as `hob-hmi` through the
//! gateway; none can gain privileges, each sees the file system read-only but for hob's own
//! state and the bus (so none can write the machine file in /etc/hob), and only the loop and
//! the watchdog hold a capability, each the ones it needs (README, "Deploying on the
//! machine PC").
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
        ("hob-rt.service", "CAP_SYS_NICE CAP_IPC_LOCK", "hob"),
        ("hob-watchdog.service", "CAP_SYS_NICE", "hob"),
        ("hob-logger.service", "", "hob"),
        ("hob-gateway.service", "", "hob"),
        ("hob-hmi.service", "", "hob-hmi"),
    ];
    for (unit, allowed, user) in caps {
        let k = service_keys(unit);
        let get = |key: &str| k.get(key).map(String::as_str);
        assert_eq!(get("User"), Some(user), "{unit}");
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

/// The HMI faces people: it is not a process of the bus (its user cannot open the bus's
/// files) but reaches the loop through the gateway's socket, and may write only the library;
/// the gateway lets the operators' group command and the viewers' group watch.
#[test]
fn the_hmi_reaches_the_loop_through_the_gateway_as_a_user_of_the_operators_group() {
    let hmi = service_keys("hob-hmi.service");
    let gateway = service_keys("hob-gateway.service");
    let socket = hmi
        .get("Environment")
        .and_then(|e| e.strip_prefix("HOB_GATEWAY="))
        .expect("hob-hmi.service: Environment=HOB_GATEWAY=...");
    let exec = gateway.get("ExecStart").map(String::as_str).unwrap_or("");
    let args: Vec<&str> = exec.split_whitespace().collect();
    let value = |flag: &str| {
        args.iter()
            .position(|a| *a == flag)
            .and_then(|i| args.get(i + 1))
            .copied()
    };
    assert_eq!(
        value("--socket"),
        Some(socket),
        "the gateway listens where the HMI looks"
    );
    assert_eq!(
        value("--operators"),
        hmi.get("Group").map(String::as_str),
        "the HMI's group commands"
    );
    assert_eq!(value("--viewers"), Some("hob-view"));
    // The user levels' groups: setters change tools and corrections, builders everything.
    assert_eq!(value("--setters"), Some("hob-set"));
    assert_eq!(value("--builders"), Some("hob-build"));
    assert!(socket.starts_with("/run/hob/"), "{socket}");
    assert_eq!(gateway.get("RuntimeDirectory").map(String::as_str), Some("hob"));
    assert_eq!(
        hmi.get("ReadWritePaths").map(String::as_str),
        Some("/var/lib/hob/library"),
        "the HMI writes the library alone, not the bus's files in /tmp"
    );
}
