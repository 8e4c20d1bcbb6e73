#![no_main]
//! See hob_fuzz_harness::gateway for the properties asserted.

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| hob_fuzz_harness::gateway(data));
