//! Replays every committed corpus input, hand-written seed and past crash of each fuzz target
//! through its properties (`hob_fuzz_harness::TARGETS`): on stable, in the test command.

use hob_rt_os::alloc_guard::{CountingAllocator, counts};
use std::path::Path;

// The `cyclic` target's "never allocates" is checked where this allocator counts.
#[global_allocator]
static ALLOC: CountingAllocator = CountingAllocator;

/// The heap counts are the process's: one test at a time (`cargo test` runs them on threads).
static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());

#[test]
fn every_corpus_input_and_past_crash_keeps_its_properties() {
    let _one = ONE_AT_A_TIME
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz");
    let mut replayed = 0;
    for (name, target) in hob_fuzz_harness::TARGETS {
        let mut seen = 0;
        for kind in ["corpus", "seeds", "regressions"] {
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
    assert!(
        counts().is_some(),
        "the counting allocator is not the global one: nothing was checked"
    );
    println!("replayed {replayed} inputs");
}

#[test]
fn the_heap_check_sees_an_allocation() {
    let _one = ONE_AT_A_TIME
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let caught = std::panic::catch_unwind(|| hob_fuzz_harness::no_heap("a Vec", || vec![1u8; 64].len()));
    assert!(caught.is_err(), "an allocation inside the check went unseen");
    assert_eq!(hob_fuzz_harness::no_heap("nothing", || 2 + 2), 4);
}
