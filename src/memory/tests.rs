use super::*;

#[test]
fn meminfo_parsing_and_refusals() {
    let text = "MemTotal:       16000000 kB\nMemFree:  100 kB\nMemAvailable:    8000000 kB\n";
    assert_eq!(meminfo_field(text, "MemAvailable:"), Some(8_000_000 * 1024));
    assert_eq!(meminfo_field(text, "Nope:"), None);
    assert!(check_host_against("x", 1000, Some(1000)).is_ok());
    let e = check_host_against("rows (900 x 100000 lights x RGB float32)", 1_080_000_000, Some(500_000_000)).unwrap_err();
    assert!(matches!(e, Error::OutOfMemory(_)));
    let msg = e.to_string();
    assert!(msg.contains("rows (900 x 100000") && msg.contains("1.08 GB") && msg.contains("500.0 MB"), "{msg}");
    let e = check_host_against("huge", product(&[u64::MAX, 4]), None).unwrap_err().to_string();
    assert!(e.contains("address"), "{e}");
    assert_eq!(product(&[3, 4, 5]), 60);
    assert_eq!(parse_bytes("64M"), Some(64 << 20));
    assert_eq!(parse_bytes("2GiB"), Some(2 << 30));
    assert_eq!(parse_bytes("1000"), Some(1000));
    assert_eq!(parse_bytes("abc"), None);
}

#[test]
fn thread_limit_bounds_this_thread_only() {
    let outer = available_host_bytes().unwrap();
    let inner = with_thread_limit(1 << 20, || {
        let here = available_host_bytes().unwrap();
        let nested = with_thread_limit(1 << 30, || available_host_bytes().unwrap());
        let other = std::thread::spawn(|| available_host_bytes().unwrap()).join().unwrap();
        let e = check_host("a 2 MiB test buffer", 2 << 20).unwrap_err();
        assert!(matches!(e, Error::OutOfMemory(_)) && e.to_string().contains("1.0 MB is available"), "{e}");
        (here, nested, other.is_none_or(|o| o > 1 << 20))
    });
    assert_eq!(inner, (Some(1 << 20), Some(1 << 20), true));
    let after = available_host_bytes().unwrap();
    assert_eq!(after.is_some(), outer.is_some());
    assert!(after.is_none_or(|a| a > 1 << 20), "{after:?}");
}

#[test]
fn available_memory_is_known_on_linux() {
    if cfg!(target_os = "linux") {
        let a = available_host_bytes().unwrap().expect("/proc/meminfo");
        assert!(a > 1 << 20, "{a}");
    }
}

#[test]
fn address_space_and_data_limits_bound_the_room() {
    let limits = "Limit                     Soft Limit           Hard Limit           Units     \n\
                  Max data size             unlimited            unlimited            bytes     \n\
                  Max address space         1536000000           unlimited            bytes     \n";
    let status = "Name:\tpython\nVmSize:\t  500000 kB\nVmData:\t  300000 kB\n";
    assert_eq!(rlimit_room(limits, status), Some(1_536_000_000 - 500_000 * 1024));
    let both = limits.replace("Max data size             unlimited", "Max data size             400000000");
    assert_eq!(rlimit_room(&both, status), Some(400_000_000 - 300_000 * 1024));
    let none = limits.replace("1536000000", "unlimited");
    assert_eq!(rlimit_room(&none, status), None);
    // Above the limit already: no room at all.
    assert_eq!(rlimit_room(limits, "VmSize:\t 2000000 kB\n"), Some(0));
}
