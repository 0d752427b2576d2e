//! Running the built `meshsmooth` binary from the end-to-end tests.

use std::path::Path;
use std::process::{Command, Output};

pub fn meshsmooth(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_meshsmooth"))
        .args(args)
        .output()
        .expect("runs")
}

/// stdout then stderr.
pub fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}
