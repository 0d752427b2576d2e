//! The `meshsmooth` command-line tool: a thin shell over the library.

mod cli;

fn main() {
    // Like any Unix filter, die quietly of SIGPIPE when the reader goes away
    // (`meshsmooth quality X | head -1`) instead of panicking in println!.
    // Outputs are written atomically, so no partial mesh file is left.
    #[cfg(unix)]
    // SAFETY: still single-threaded; SIG_DFL is a valid disposition.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    // Mesa's device-select Vulkan layer probes the display server and prints
    // errors on headless machines; meshsmooth chooses adapters itself.
    if std::env::var_os("NODEVICE_SELECT").is_none() {
        // SAFETY: still single-threaded; nothing else reads the environment yet.
        unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
    }
    std::process::exit(cli::run(std::env::args_os()));
}
