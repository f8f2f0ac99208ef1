//! The `sism` command line: the commands layer lives in `cli/`; the work lives in the library.

mod cli;

/// mimalloc keeps freed pages for reuse: the frame's large buffers (tens of MB each) would otherwise
/// be returned to the OS and page-faulted in again by the next phase. `LineAlloc` around it makes
/// counted frames repeatable (line-aligned blocks, no reuse within a counted frame).
#[global_allocator]
static GLOBAL: sism_simd::LineAlloc<mimalloc::MiMalloc> = sism_simd::LineAlloc(mimalloc::MiMalloc);

fn main() -> std::process::ExitCode {
    cli::main()
}
