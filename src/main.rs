//! The `sism` command line: the commands layer lives in `cli/`; the work lives in the library.

mod cli;

/// mimalloc keeps freed pages for reuse: the frame's large buffers (tens of MB each) would otherwise
/// be returned to the OS and page-faulted in again by the next phase. `LineAlloc` around it makes
/// counted frames repeatable (line-aligned blocks, no reuse within a counted frame).
#[global_allocator]
static GLOBAL: sism_simd::LineAlloc<mimalloc::MiMalloc> = sism_simd::LineAlloc(mimalloc::MiMalloc);

/// mimalloc's `mi_option_purge_delay` (mimalloc.h's `mi_option_e`; libmimalloc-sys names no constant
/// for it).
const MI_OPTION_PURGE_DELAY: libmimalloc_sys::mi_option_t = 15;

fn main() -> std::process::ExitCode {
    // Freed pages are kept, never purged (the default purges them 10 ms after a free): a frame's
    // buffers are page-faulted in once, not again in every phase and frame (measured: 16% of a
    // 1600×1200 palm frame in clear_page). Memory held stays at the run's peak.
    // SAFETY: sets an option of the global allocator before any thread is started.
    unsafe { libmimalloc_sys::mi_option_set(MI_OPTION_PURGE_DELAY, -1) };
    cli::main()
}
