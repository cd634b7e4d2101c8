//! The `limitray` command-line tool: everything is in the library's `cli` module.

/// Huge pages under the build's large arrays ([`limitray::huge_pages`]).
#[global_allocator]
static ALLOC: limitray::huge_pages::HugePageAlloc = limitray::huge_pages::HugePageAlloc;

fn main() -> std::process::ExitCode {
    limitray::cli::main()
}
