//! The README's library example: read a mesh, smooth it, print the reports,
//! write it. Run: cargo run --release --example smooth_file -- IN.vtk OUT.vtk
//! (without arguments it writes and smooths a perturbed box in a temp folder).

use meshsmooth::Smoother;
use meshsmooth::smoother::Event;
use meshsmooth::solve::Method;

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
    // the command line's defaults: auto device, auto targets, untangling first
    let mut smoother = Smoother::default();
    smoother.method = Method::Newton;
    let report = smoother.smooth_observed(&mut mesh, &mut |event| {
        if let Event::Iteration(rec) = event {
            eprintln!("iteration {}: F = {:.8}", rec.iteration, rec.objective);
        }
        true // return false to stop early
    })?;
    println!(
        "{}\n{}\n{} after {} iterations on {}",
        report.start.quality, report.quality, report.info.stop, report.info.iterations, report.info.device
    );
    // refuses to write an inverted element; adds the quality as cell data
    meshsmooth::io::write_mesh(&output, &mesh, meshsmooth::io::Format::VtkAscii)
}
