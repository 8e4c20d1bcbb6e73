#![no_main]
//! See hob_fuzz_harness::cyclic for the properties asserted.

use libfuzzer_sys::fuzz_target;

// Counts the heap operations of the master's cyclic calls: the target asserts there are none.
#[global_allocator]
static ALLOC: hob_fuzz_harness::CountingAllocator = hob_fuzz_harness::CountingAllocator;

fuzz_target!(|data: &[u8]| hob_fuzz_harness::cyclic(data));
