//! Image fuzz target: the file extension is this target's name (copy this file to add a format, see
//! fuzz/README.md). Errors are fine; panics, aborts and hangs are findings.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let _ = manylights::fuzzing::image(data, env!("CARGO_BIN_NAME"));
});
