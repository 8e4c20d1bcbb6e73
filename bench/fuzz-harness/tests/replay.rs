//! Replays every committed corpus input and past crash of each fuzz target through its
//! properties (`hob_fuzz_harness::TARGETS`): on stable, in the test command.

use std::path::Path;

#[test]
fn every_corpus_input_and_past_crash_keeps_its_properties() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz");
    let mut replayed = 0;
    for (name, target) in hob_fuzz_harness::TARGETS {
        let mut seen = 0;
        for kind in ["corpus", "regressions"] {
            let dir = root.join(kind).join(name);
            let Ok(entries) = std::fs::read_dir(&dir) else {
                continue;
            };
            for e in entries.flatten() {
                let data = std::fs::read(e.path()).unwrap_or_default();
                let path = e.path();
                let result = std::panic::catch_unwind(|| target(&data));
                assert!(result.is_ok(), "{name}: {} breaks its properties", path.display());
                seen += 1;
            }
        }
        assert!(seen > 0, "{name}: no corpus under {}", root.display());
        replayed += seen;
    }
    println!("replayed {replayed} inputs");
}
