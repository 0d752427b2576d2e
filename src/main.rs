//! The `meshsmooth` command-line tool: a thin shell over the library.

mod cli;

fn main() {
    std::process::exit(cli::run(std::env::args_os()));
}
