use super::*;

#[test]
fn a_trial_of_a_few_threads_succeeds_and_leaves_none_running() {
    assert!(trial(1));
    assert!(trial(8));
    let count = || std::fs::read_to_string("/proc/self/status").unwrap().lines().find(|l| l.starts_with("Threads:")).unwrap().to_string();
    let before = count();
    assert!(trial(16));
    assert_eq!(count(), before, "the trial's threads must all be joined");
}

#[test]
fn a_trial_past_the_address_space_fails_without_panicking() {
    // In a child process (the limit is process-wide): 100,000 threads of 2 MiB stacks need 200 GB of address
    // space; under a 1 GB limit `trial` must return false, not abort. The child starts with SIGSEGV and SIGBUS
    // ignored, so that, as in the Python extension module (no Rust `main`), Rust's runtime installs no
    // stack-overflow handler and its threads map no signal stack of their own: a test binary's thread started
    // in the last KiB below the limit aborted the process mapping that stack ("failed to allocate an
    // alternative stack"), which the module never does.
    if std::env::var("MANYLIGHTS_THREADS_CHILD").is_ok() {
        assert!(std::fs::read_to_string("/proc/self/limits")
            .unwrap()
            .lines()
            .any(|l| l.starts_with("Max address space") && l.contains("1073741824")));
        assert!(!trial(100_000));
        assert!(trial(1));
        return;
    }
    let exe = std::env::current_exe().unwrap();
    let out = std::process::Command::new("sh")
        .args([
            "-c",
            "trap '' SEGV BUS && ulimit -v 1048576 && exec \"$0\" --exact threads::tests::a_trial_past_the_address_space_fails_without_panicking --nocapture",
        ])
        .arg(exe)
        .env("MANYLIGHTS_THREADS_CHILD", "1")
        .output()
        .unwrap();
    assert!(out.status.success(), "child failed: {}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stdout).contains("1 passed"));
}
