//! The `chassis-mc` command line (`chassis_mc::cli`): parse flags, call the library, map
//! errors to exit codes (0 success, 1 failure while running, 2 bad study file or arguments).

use std::process::ExitCode;

fn main() -> ExitCode {
    tune_allocator();
    ExitCode::from(chassis_mc::cli::main(std::env::args_os()))
}

/// With glibc, serve allocations of 128 KiB and more by mmap and give them back when freed.
/// glibc otherwise raises that threshold after such a block is freed, and the column buffers
/// Parquet allocates and frees per row group then fragment the heap: a run's peak memory
/// crept up with its length (179 MB at R = 100 000 on the thesis study against 140 MB at
/// R = 10 000; README, "Performance").
#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn tune_allocator() {
    // SAFETY: mallopt only sets an allocator parameter; called before any other thread runs.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 128 * 1024);
    }
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn tune_allocator() {}
