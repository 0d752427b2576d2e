//! Strong scaling of partitioned smoothing over 1 to 4 MPI ranks (the built
//! binary under `mpirun`), the communication each rank count costs per BCD
//! sweep and per CG iteration, and a model of that traffic extrapolated to
//! 1e9 tetrahedra on 1000 ranks.
//!
//! Halo bytes are those all ranks send together: per iteration (a BCD
//! sweep: one exchange per colour, of that colour's ghosts; a Newton step:
//! one exchange per CG iteration and per line-search trial) and per
//! exchange (for Newton, what one CG iteration sends).
//!
//! Newton runs on both partitioners (METIS on the vertex graph, recursive
//! coordinate bisection), so their cuts and traffic compare; the traffic
//! model uses METIS's ghosts. It runs a third time from the box written as
//! P pieces (RCB), each rank setting up its own part (`--partitioner
//! pieces`), where rank 0 never holds the whole mesh: the memory columns
//! (the largest part's vertices, owned and ghosts; each rank's peak RSS)
//! show what that saves rank 0.
//!
//! Run: cargo bench --features mpi --bench mpi_scaling [-- --cells N]
//! (default N = 16: a perturbed box of 6 N^3 tetrahedra). Times are wall
//! times of the solver loop on the slowest rank; on a machine with fewer
//! cores than ranks they measure oversubscription, not scaling.

use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_meshsmooth");

/// Bytes of one free ghost position (or vector block) in a halo exchange.
const BYTES_PER_GHOST: f64 = 24.0;

struct Measured {
    wall: f64,
    comm: f64,
    exchanges: f64,
    bytes: f64,
    reductions: f64,
    iterations: f64,
    ghost_fraction: f64,
    halo_values: f64,
    edge_cut: f64,
    largest_part: f64,
    rss_rank0: f64,
    rss_max: f64,
}

fn number_after(text: &str, key: &str) -> f64 {
    let at = text.find(key).unwrap_or_else(|| panic!("no '{key}' in:\n{text}")) + key.len();
    let s: String = text[at..]
        .trim_start()
        .chars()
        .take_while(|c| c.is_ascii_digit() || *c == '.' || *c == 'e' || *c == '-')
        .collect();
    s.parse().unwrap_or_else(|_| panic!("'{key}' followed by '{s}'"))
}

/// `input` written as `parts` pieces (RCB, no iteration); the index.
fn pieces(input: &str, parts: usize) -> String {
    let index = std::env::temp_dir().join(format!("mpi_scaling_pieces_{parts}.pvtu"));
    let o = Command::new(BIN)
        .args(["smooth", input, "-o"])
        .arg(&index)
        .args([
            "--pieces",
            &parts.to_string(),
            "--partitioner",
            "rcb",
            "--max-iter",
            "0",
            "--quiet",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    index.to_string_lossy().into_owned()
}

fn run(ranks: usize, input: &str, method: &str, partitioner: &str) -> Measured {
    let out = std::env::temp_dir().join(format!("mpi_scaling_{ranks}_{method}_{partitioner}.vtu"));
    let o = Command::new("mpirun")
        .args([
            "--allow-run-as-root",
            "--oversubscribe",
            "-np",
            &ranks.to_string(),
            BIN,
            "smooth",
            input,
            "-o",
        ])
        .arg(&out)
        .args(["--method", method, "--device", "cpu", "--partitioner", partitioner])
        .output()
        .expect("mpirun runs");
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(o.status.success(), "{text}\n{}", String::from_utf8_lossy(&o.stderr));
    let summary = text.lines().find(|l| l.contains(" on mpi (")).unwrap_or("");
    Measured {
        wall: number_after(&text, "mpi time (slowest rank):"),
        comm: number_after(&text, "and communication"),
        exchanges: number_after(&text, "mpi traffic:"),
        bytes: number_after(&text, "halo exchanges ("),
        reductions: number_after(&text, "per iteration),"),
        iterations: number_after(summary, "after"),
        ghost_fraction: number_after(&text, "ghost fraction"),
        halo_values: number_after(&text, "(corners),"),
        edge_cut: number_after(&text, "edge cut"),
        largest_part: number_after(&text, "largest part"),
        rss_rank0: number_after(&text, "peak RSS per rank (MiB)"),
        rss_max: number_after(&text, "(max"),
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let cells: usize = args
        .iter()
        .position(|a| a == "--cells")
        .and_then(|i| args.get(i + 1))
        .and_then(|s| s.parse().ok())
        .unwrap_or(16);
    let input = std::env::temp_dir().join(format!("mpi_scaling_box_{cells}.vtu"));
    let n = cells.to_string();
    let o = Command::new(BIN)
        .args([
            "generate",
            "box",
            "--cells",
            &n,
            &n,
            &n,
            "--perturb",
            "random:0.3",
            "-o",
        ])
        .arg(&input)
        .output()
        .unwrap();
    assert!(o.status.success());
    let input = input.to_str().unwrap();
    let tets = 6 * cells * cells * cells;
    println!("# MPI strong scaling: perturbed tet box, {tets} tetrahedra, {cells}^3 cubes\n");
    println!(
        "| method | partitioner | ranks | iterations | wall s | speed-up | comm % | edge cut | ghost fraction | free ghosts | halo bytes per iteration | halo bytes per exchange | exchanges | reductions | largest part (vertices) | peak RSS rank 0 / max MiB |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut ghost_model = Vec::new();
    let mut newton_one = None;
    for (method, partitioner) in [
        ("bcd-colored", "metis"),
        ("newton", "metis"),
        ("newton", "rcb"),
        ("newton", "pieces"),
    ] {
        let mut base = None;
        // pieces need 2 ranks at least; their speed-up is against Newton on one
        for ranks in if partitioner == "pieces" { 2..=4 } else { 1..=4 } {
            let from = if partitioner == "pieces" {
                pieces(input, ranks)
            } else {
                input.to_string()
            };
            let m = run(ranks, &from, method, partitioner);
            if method == "newton" && ranks == 1 {
                newton_one.get_or_insert(m.wall);
            }
            let t1 = *base.get_or_insert(if partitioner == "pieces" {
                newton_one.unwrap_or(m.wall)
            } else {
                m.wall
            });
            println!(
                "| {method} | {partitioner} | {ranks} | {:.0} | {:.3} | {:.2} | {:.0} | {:.0} | {:.3} | {:.0} | {:.0} | {:.0} | {:.0} | {:.0} | {:.0} | {:.1} / {:.1} |",
                m.iterations,
                m.wall,
                t1 / m.wall,
                100.0 * m.comm / m.wall.max(1e-300),
                m.edge_cut,
                m.ghost_fraction,
                m.halo_values,
                m.bytes / m.iterations.max(1.0),
                m.bytes / m.exchanges.max(1.0),
                m.exchanges,
                m.reductions,
                m.largest_part,
                m.rss_rank0,
                m.rss_max
            );
            if method == "newton" && partitioner == "metis" && ranks > 1 {
                ghost_model.push((ranks, m.halo_values));
            }
        }
    }
    // Ghosts of a part scale with its surface: g ~ c (V/P)^(2/3) per part.
    let vertices = ((cells + 1) * (cells + 1) * (cells + 1)) as f64;
    let c = ghost_model
        .iter()
        .map(|&(p, g)| (g / p as f64) / (vertices / p as f64).powf(2.0 / 3.0))
        .fold(0.0, f64::max);
    let (big_tets, big_ranks): (f64, f64) = (1e9, 1000.0);
    let per_rank = big_tets / 6.0 / big_ranks;
    let ghosts = c * per_rank.powf(2.0 / 3.0);
    let bytes = BYTES_PER_GHOST * ghosts;
    println!("\n## Traffic model");
    println!(
        "bytes per exchange per rank = {BYTES_PER_GHOST} bytes per free ghost vertex x ghosts, ghosts = c (V/P)^(2/3) with c = {c:.2} (measured, worst of 2-4 ranks)"
    );
    println!(
        "1e9 tetrahedra on 1000 ranks: {per_rank:.3e} vertices per rank, {ghosts:.3e} ghosts, {:.1} MB per halo exchange per rank ({:.1}% of the rank's positions);",
        bytes / 1e6,
        100.0 * ghosts / per_rank
    );
    println!(
        "  per CG iteration one exchange ({:.1} MB) and 3 reductions (8 B x 1000 ranks gathered each, rank-order sum);",
        bytes / 1e6
    );
    println!(
        "  per coloured BCD sweep one exchange per colour, each of the ghosts of that colour only (about {:.1} MB over the sweep).",
        bytes / 1e6
    );
}
