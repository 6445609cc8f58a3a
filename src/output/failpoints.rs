//! Failpoints and pause points: named instants of writing or reading the output at which
//! the tests stop a run, or hold a reader while they change the directory.

/// The points [`failpoint`] is called at.
pub const FAILPOINTS: [&str; 6] = [
    "part-committed",
    "figure-drawn",
    "before-journal",
    "journal-written",
    "commit-rename",
    "committed",
];

/// A testing hook: abort the process (as a SIGKILL would stop it: no destructor runs) the
/// N-th time the point `name` is reached, when the environment variable
/// `CHASSIS_MC_FAILPOINT` is `name` or `name:N` (N = 1 by default). The crash tests use it
/// to stop a run at exact instants of writing its output.
pub fn failpoint(name: &str) {
    use std::sync::OnceLock;
    use std::sync::atomic::{AtomicU64, Ordering};
    static TARGET: OnceLock<Option<(String, u64)>> = OnceLock::new();
    static HITS: AtomicU64 = AtomicU64::new(0);
    let target = TARGET.get_or_init(|| {
        let value = std::env::var("CHASSIS_MC_FAILPOINT").ok()?;
        let (point, n) = value.split_once(':').unwrap_or((&value, "1"));
        if !FAILPOINTS.contains(&point) {
            eprintln!(
                "warning: CHASSIS_MC_FAILPOINT: no failpoint \"{point}\"; known: {FAILPOINTS:?}"
            );
        }
        Some((point.to_string(), n.parse().unwrap_or(1)))
    });
    if let Some((point, n)) = target
        && point == name
        && HITS.fetch_add(1, Ordering::SeqCst) + 1 == *n
    {
        std::process::abort();
    }
}

/// The points [`pause`] is called at: a reader's input file just opened (before it is
/// checked against the manifest), and a summary between its two passes over the
/// realisations.
pub const PAUSE_POINTS: [&str; 2] = ["input-opened", "between-passes"];

/// A testing hook: when the environment variable `CHASSIS_MC_PAUSE` is `name:FILE`, the
/// first time the point `name` is reached the process creates `FILE.paused` and waits
/// until `FILE` exists (polling every 10 ms). The tests use it to change a directory at an
/// exact instant of a reader's work (e.g. a run replacing the file a summary is reading).
/// Unset, it costs one read of a cached value.
pub fn pause(name: &str) {
    use std::path::PathBuf;
    use std::sync::OnceLock;
    use std::sync::atomic::{AtomicBool, Ordering};
    static TARGET: OnceLock<Option<(String, PathBuf)>> = OnceLock::new();
    static DONE: AtomicBool = AtomicBool::new(false);
    let target = TARGET.get_or_init(|| {
        let value = std::env::var("CHASSIS_MC_PAUSE").ok()?;
        let Some((point, file)) = value.split_once(':') else {
            eprintln!("warning: CHASSIS_MC_PAUSE: expected POINT:FILE, got \"{value}\"");
            return None;
        };
        if !PAUSE_POINTS.contains(&point) {
            eprintln!("warning: CHASSIS_MC_PAUSE: no point \"{point}\"; known: {PAUSE_POINTS:?}");
        }
        Some((point.to_string(), PathBuf::from(file)))
    });
    if let Some((point, file)) = target
        && point == name
        && !DONE.swap(true, Ordering::SeqCst)
    {
        let mut paused = file.clone().into_os_string();
        paused.push(".paused");
        let _ = std::fs::write(&paused, std::process::id().to_string());
        while !file.exists() {
            std::thread::sleep(std::time::Duration::from_millis(10));
        }
    }
}
