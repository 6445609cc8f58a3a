//! Failpoints: named instants of writing the output at which the crash tests stop a run.

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
