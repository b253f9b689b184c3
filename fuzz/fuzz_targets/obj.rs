//! Fuzz target: `manylights::fuzzing::obj` (see src/fuzzing.rs). Errors are fine; panics, aborts and hangs are findings.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let _ = manylights::fuzzing::obj(data);
});
