//! Untangles a mesh file, then smooths it: `cargo run --release --example
//! untangle_file -- IN OUT`.

use meshsmooth::solve::{self, Method, Options, Params, UntangleParams};

fn main() -> meshsmooth::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let [_, input, output] = &args[..] else {
        eprintln!("usage: untangle_file IN OUT");
        std::process::exit(2);
    };
    let mut mesh = meshsmooth::io::read(input)?;
    let opts = Options::cpu(Method::Newton, &Params::default());
    let problem = Default::default();
    let info = solve::untangle_mesh(&mut mesh, &problem, &opts, &UntangleParams::default(), &mut |_| true)?;
    println!(
        "{} inverted element(s) untangled in {} round(s) of eps",
        info.inverted_before, info.rounds
    );
    let info = solve::smooth_mesh(&mut mesh, &problem, &opts, &mut |_| true)?;
    println!("smoothed: F = {:.6} ({:?})", info.objective, info.stop);
    meshsmooth::io::write_mesh(
        output.as_ref(),
        &mesh,
        meshsmooth::io::Format::from_path(output.as_ref())?,
    )
}
