//! The README's library example: read a mesh, smooth it, print the reports,
//! write it. Run: cargo run --release --example smooth_file -- IN.vtk OUT.vtk
//! (without arguments it writes and smooths a perturbed box in a temp folder).

use meshsmooth::solve::{self, Method, Options, Params};

fn main() -> meshsmooth::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let dir = std::env::temp_dir();
    let (input, output) = match args.as_slice() {
        [i, o] => (i.into(), o.into()),
        _ => {
            let mut m = meshsmooth::generate::tet_box(8, 8, 8, [1.0; 3]);
            let p = meshsmooth::generate::PerturbOptions {
                perturbation: "random:0.3".parse()?,
                fraction: 1.0,
                seed: 1,
            };
            meshsmooth::generate::perturb(&mut m, &p)?;
            let i = dir.join("meshsmooth-example-in.vtk");
            meshsmooth::io::write(&i, &m, meshsmooth::io::Format::VtkAscii, &[])?;
            (i, dir.join("meshsmooth-example-out.vtk"))
        }
    };
    // -- the README example --
    let mut mesh = meshsmooth::io::read(&input)?;
    let before = meshsmooth::report::quality_report(&mesh, &mesh.points);
    let opts = Options::cpu(Method::Newton, &Params::default());
    let info = solve::smooth_mesh(&mut mesh, &Default::default(), &opts, &mut |rec| {
        eprintln!("iteration {}: F = {:.8}", rec.iteration, rec.objective);
        true // return false to stop early
    })?;
    let after = meshsmooth::report::quality_report(&mesh, &mesh.points);
    println!(
        "{before}\n{after}\n{:?} after {} iterations",
        info.stop, info.iterations
    );
    // refuses to write an inverted element; adds the quality as cell data
    meshsmooth::io::write_mesh(&output, &mesh, meshsmooth::io::Format::VtkAscii)
}
