//! The whole `smooth` command from file to file against its setup and
//! solve: a perturbed N³ box (6 N³ tetrahedra, binary VTU in and out), five
//! coloured BCD sweeps, the command's own `time:` line read back. Writes
//! results/whole-command.md.
//!
//! cargo bench --bench whole_command -- [--n 40] [--reps 5]

mod common;

use meshsmooth::generate::{self, PerturbOptions, Perturbation};
use std::fmt::Write;
use std::process::Command;

/// The seconds of each part of a `time: read X s, setup Y s, ...` line.
fn parts(line: &str) -> Vec<(String, f64)> {
    line.trim_start_matches("time: ")
        .split([',', ';'])
        .filter_map(|p| {
            let mut w = p.split_whitespace();
            let (a, b) = (w.next()?, w.next()?);
            // "read 0.1 s" or "2.3 s in all"
            match (a.parse::<f64>(), b.parse::<f64>()) {
                (Ok(s), _) => Some(("all".to_string(), s)),
                (_, Ok(s)) => Some((a.to_string(), s)),
                _ => None,
            }
        })
        .collect()
}

fn main() {
    let n: usize = common::arg("--n").map_or(40, |v| v.parse().unwrap());
    let reps: usize = common::arg("--reps").map_or(5, |v| v.parse().unwrap());
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("box.vtu");
    let output = dir.path().join("out.vtu");
    let mut mesh = generate::tet_box(n, n, n, [1.0; 3]);
    let opts = PerturbOptions {
        perturbation: Perturbation::Random { alpha: 0.3 },
        seed: 1,
        ..Default::default()
    };
    generate::perturb(&mut mesh, &opts).unwrap();
    meshsmooth::io::write(&input, &mesh, meshsmooth::io::Format::VtuBinary, &[]).unwrap();
    let args = ["smooth", "--method", "bcd-colored", "--max-iter", "5"];
    let mut runs: Vec<Vec<(String, f64)>> = Vec::new();
    for _ in 0..reps + 1 {
        let out = Command::new(env!("CARGO_BIN_EXE_meshsmooth"))
            .args(args)
            .arg(&input)
            .arg("-o")
            .arg(&output)
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let text = String::from_utf8_lossy(&out.stdout);
        let line = text.lines().find(|l| l.starts_with("time:")).expect("a time: line");
        runs.push(parts(line));
        let written = std::fs::read(&output).unwrap();
        let head = String::from_utf8_lossy(&written[..written.len().min(4096)]).to_string();
        assert!(
            !head.contains("format=\"ascii\""),
            "the binary input came back as ASCII"
        );
    }
    // the first run warms the page cache and the drivers
    runs.remove(0);
    let median_of = |name: &str| {
        common::median(
            runs.iter()
                .map(|r| r.iter().find(|(k, _)| k == name).unwrap().1)
                .collect(),
        )
    };
    let names = ["read", "setup", "solve", "write", "other", "all"];
    let m: Vec<f64> = names.iter().map(|k| median_of(k)).collect();
    let over = |r: &Vec<(String, f64)>| {
        let get = |k: &str| r.iter().find(|(n, _)| n == k).unwrap().1;
        get("all") / (get("setup") + get("solve")) - 1.0
    };
    let overs = common::median(runs.iter().map(over).collect());
    let mut md = String::from("# The whole command\n\n");
    md += &common::provenance(&format!("cargo bench --bench whole_command -- --n {n} --reps {reps}"));
    writeln!(
        md,
        "\n`meshsmooth {} BOX.vtu -o OUT.vtu` on a {n}³ box ({} tetrahedra, {} vertices, random:0.3, binary VTU in and out, written back binary), the command's own `time:` line, medians of {reps} runs after one warm-up:\n",
        args.join(" "),
        mesh.num_elements(),
        mesh.num_points()
    )
    .unwrap();
    md += "| read | setup | solve | write | other | in all | over setup + solve |\n|---|---|---|---|---|---|---|\n";
    writeln!(
        md,
        "| {:.3} s | {:.3} s | {:.3} s | {:.3} s | {:.3} s | {:.3} s | {:.0}% |",
        m[0],
        m[1],
        m[2],
        m[3],
        m[4],
        m[5],
        100.0 * overs
    )
    .unwrap();
    md += "\n\"other\" is what the command does besides reading, setting up, solving and writing: the checks, the default targets' test, the choice of device, the reports before and after.\n";
    print!("{md}");
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("results/whole-command.md");
    std::fs::write(&path, md).unwrap();
    eprintln!("wrote {}", path.display());
}
