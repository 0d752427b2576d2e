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

/// `meshsmooth generate box` with a random perturbation, asserting success.
pub fn generate_box(out: &Path, cells: [usize; 3], perturb: &str, seed: u64) {
    let (c, seed) = (cells.map(|n| n.to_string()), seed.to_string());
    let args = [
        "generate",
        "box",
        "--cells",
        &c[0],
        &c[1],
        &c[2],
        "--perturb",
        perturb,
        "--seed",
        &seed,
        "-o",
        s(out),
    ];
    let o = meshsmooth(&args);
    assert!(o.status.success(), "{}", text(&o));
}
