//! The command line is a front end of the library's `Smoother`: the same
//! defaults, the same checks and the same answer; `--config` files.

use crate::common::cli::{meshsmooth, s, text};
use meshsmooth::generate::{self, PerturbOptions, Perturbation};
use meshsmooth::io::{self, Format};
use meshsmooth::{DeviceChoice, Error, Smoother, metric};

/// A perturbed tetrahedral box with one interior vertex pushed through its neighbours.
fn tangled_box() -> meshsmooth::Mesh {
    let mut mesh = generate::tet_box(4, 4, 4, [1.0, 1.0, 1.0]);
    let opts = PerturbOptions {
        perturbation: Perturbation::Random { alpha: 0.2 },
        fraction: 1.0,
        seed: 5,
    };
    generate::perturb(&mut mesh, &opts).unwrap();
    let v = (0..mesh.num_points())
        .find(|&v| mesh.points[v].iter().all(|&c| c > 0.4 && c < 0.6))
        .unwrap();
    mesh.points[v][0] += 0.45;
    assert!(!metric::inverted_elements(&mesh, &mesh.points).is_empty());
    mesh
}

#[test]
fn cli_and_library_give_the_same_mesh_untangling_included() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("tangled.vtu");
    let mesh = tangled_box();
    io::write(&input, &mesh, Format::VtuBinary, &[]).unwrap();
    for method in ["newton", "bcd", "nlcg"] {
        let out = dir.path().join(format!("{method}.vtu"));
        let o = meshsmooth(&[
            "smooth",
            s(&input),
            "-o",
            s(&out),
            "--format",
            "vtu-binary",
            "--device",
            "cpu",
            "--method",
            method,
        ]);
        assert!(o.status.success(), "{}", text(&o));
        assert!(text(&o).contains("untangled"), "{}", text(&o));
        let mut by_library = io::read(&input).unwrap();
        let mut smoother = Smoother::default();
        smoother.device = DeviceChoice::Cpu;
        smoother.method = method.parse().unwrap();
        let report = smoother.smooth(&mut by_library).unwrap();
        assert!(report.untangled.is_some());
        assert_eq!(report.quality.inverted, 0);
        let by_cli = io::read(&out).unwrap();
        assert_eq!(by_cli.points, by_library.points, "{method}");
    }
}

#[test]
fn a_config_file_sets_what_the_command_line_does_not_override() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("box.vtu");
    let mut mesh = tangled_box();
    mesh.points = generate::tet_box(4, 4, 4, [1.0, 1.0, 1.0]).points;
    generate::perturb(
        &mut mesh,
        &PerturbOptions {
            perturbation: Perturbation::Random { alpha: 0.3 },
            fraction: 1.0,
            seed: 2,
        },
    )
    .unwrap();
    io::write(&input, &mesh, Format::VtuBinary, &[]).unwrap();
    let config = dir.path().join("run.toml");
    std::fs::write(&config, "method = \"bcd\"\nmax_iter = 2\ndevice = \"cpu\"\n").unwrap();
    let out = dir.path().join("out.vtu");
    let o = meshsmooth(&["smooth", s(&input), "-o", s(&out), "--config", s(&config)]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        text(&o).contains("bcd on cpu") && text(&o).contains("after 2 sweeps"),
        "{}",
        text(&o)
    );
    // the command line's options win over the file's
    let o = meshsmooth(&[
        "smooth",
        s(&input),
        "-o",
        s(&out),
        "--config",
        s(&config),
        "--max-iter",
        "3",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("after 3 sweeps"), "{}", text(&o));
    // the file's settings are the library's: same answer as Smoother::from_file
    let mut by_library = io::read(&input).unwrap();
    let smoother = Smoother::from_file(&config).unwrap();
    smoother.smooth(&mut by_library).unwrap();
    let o = meshsmooth(&[
        "smooth",
        s(&input),
        "-o",
        s(&out),
        "--config",
        s(&config),
        "--format",
        "vtu-binary",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(io::read(&out).unwrap().points, by_library.points);
    // a bad file is named, with the key, and nothing is written
    for (body, said) in [
        ("methd = \"bcd\"\n", "methd"),
        ("time_limit = 0\n", "time_limit"),
        ("method = \"gauss\"\n", "gauss"),
    ] {
        std::fs::write(&config, body).unwrap();
        let out = dir.path().join("refused.vtu");
        let o = meshsmooth(&["smooth", s(&input), "-o", s(&out), "--config", s(&config)]);
        assert!(!o.status.success());
        let t = text(&o);
        assert!(t.contains("run.toml") && t.contains(said), "{t}");
        assert!(!out.exists());
    }
}

#[test]
fn bad_options_name_their_flag_on_the_command_line_and_their_key_in_the_library() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("box.vtu");
    io::write(&input, &generate::tet_box(2, 2, 2, [1.0; 3]), Format::VtuBinary, &[]).unwrap();
    let out = dir.path().join("out.vtu");
    for (flag, value, key) in [
        ("--time-limit", "0", "time_limit"),
        ("--feature-angle", "200", "feature_angle"),
        ("--inner-iterations", "0", "inner_iterations"),
        ("--tol", "-1", "tol"),
    ] {
        let o = meshsmooth(&["smooth", s(&input), "-o", s(&out), &format!("{flag}={value}")]);
        assert!(!o.status.success());
        assert!(text(&o).contains(&format!("invalid option {flag}:")), "{}", text(&o));
        let mut smoother = Smoother::default();
        let toml = format!("{key} = {value}");
        smoother = Smoother::from_toml(&toml).err().map_or(smoother, |e| {
            assert!(
                matches!(&e, Error::InvalidOption { option, .. } if *option == key),
                "{e}"
            );
            Smoother::default()
        });
        assert_eq!(smoother, Smoother::default(), "{toml} was accepted");
    }
    // a tangled input refused: the library names no flag, the command line does
    let tangled = dir.path().join("tangled.vtu");
    io::write(&tangled, &tangled_box(), Format::VtuBinary, &[]).unwrap();
    let o = meshsmooth(&["smooth", s(&tangled), "-o", s(&out), "--no-untangle", "--device", "cpu"]);
    assert!(!o.status.success());
    assert!(text(&o).contains("--no-untangle"), "{}", text(&o));
    let mut smoother = Smoother::default();
    smoother.untangle = false;
    smoother.device = DeviceChoice::Cpu;
    let e = smoother.smooth(&mut io::read(&tangled).unwrap()).unwrap_err();
    assert!(
        matches!(e, Error::Inverted { .. }) && !e.to_string().contains("--"),
        "{e}"
    );
}

#[test]
fn points_used_by_no_element_are_written_back_untouched() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("unused.vtu");
    let (mesh, unused) = crate::common::box_with_unused();
    io::write(&input, &mesh, Format::VtuBinary, &[]).unwrap();
    let read = io::read(&input).unwrap();
    let bits = crate::common::bits;
    let out = dir.path().join("smooth.vtu");
    let o = meshsmooth(&["smooth", s(&input), "-o", s(&out), "--device", "cpu"]);
    assert!(o.status.success(), "{}", text(&o));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("note: 3 points are used by no element: kept where they are"),
        "{stderr}"
    );
    let after = io::read(&out).unwrap();
    assert_eq!(after.num_points(), read.num_points());
    for &v in &unused {
        assert_eq!(bits(&after.points[v]), bits(&read.points[v]), "unused point {v} moved");
    }
    assert_eq!(after.data.point, read.data.point, "point data changed");
    assert!((0..unused[0]).filter(|&v| after.points[v] != read.points[v]).count() > 10);
    let eta = |m: &meshsmooth::Mesh| meshsmooth::report::quality_report(m, &m.points).eta.avg;
    assert!(eta(&after) < eta(&read));

    // quality reads it as it is; untangle leaves the points too
    let o = meshsmooth(&["quality", s(&input), "--json"]);
    assert!(o.status.success(), "{}", text(&o));
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(json["vertices"], read.num_points());
    assert!(String::from_utf8_lossy(&o.stderr).contains("3 points are used by no element"));
    let mut tangled = read.clone();
    let v = (0..unused[0])
        .find(|&v| tangled.points[v].iter().all(|&c| c > 0.4 && c < 0.6))
        .unwrap();
    tangled.points[v][0] += 0.45;
    let tangled_path = dir.path().join("tangled.vtu");
    io::write(&tangled_path, &tangled, Format::VtuBinary, &[]).unwrap();
    let untangled = dir.path().join("untangled.vtu");
    let o = meshsmooth(&["untangle", s(&tangled_path), "-o", s(&untangled), "--device", "cpu"]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("used by no element"), "{}", text(&o));
    let after = io::read(&untangled).unwrap();
    assert!(metric::inverted_elements(&after, &after.points).is_empty());
    for &v in &unused {
        assert_eq!(bits(&after.points[v]), bits(&read.points[v]));
    }
    assert_eq!(after.data.point, read.data.point);
}
