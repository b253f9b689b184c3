//! Fuzz target: `manylights::fuzzing::ply` (see src/fuzzing.rs). Errors are fine; panics, aborts and hangs are findings.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let _ = manylights::fuzzing::ply(data);
});
