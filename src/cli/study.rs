//! `meshsmooth study order` and `meshsmooth study newton-bcd`: the papers'
//! studies, written as Markdown, CSV (and SVG).

use super::{ExperimentArg, NewtonStudyArgs, OrderStudyArgs};
use meshsmooth::newton_study::{Crossing, NewtonStudyOptions, newton_study};
use meshsmooth::order_study::{Baseline, Experiment, OrderStudyOptions, order_study};
use meshsmooth::{Error, Result, io};
use std::time::Duration;

pub fn order(a: &OrderStudyArgs) -> Result<()> {
    let mut opts = if a.quick {
        OrderStudyOptions::quick()
    } else {
        OrderStudyOptions::full()
    };
    if !a.meshes.is_empty() {
        opts.meshes = a.meshes.clone();
    }
    if !a.sizes.is_empty() {
        if a.sizes.contains(&0) {
            return Err(Error::InvalidArgument("--sizes takes counts of at least 1".into()));
        }
        opts.sizes = a.sizes.clone();
    }
    if let Some(t) = a.baseline {
        if !(t.is_finite() && t > 0.0) {
            return Err(Error::InvalidArgument(format!(
                "--baseline must be a positive number of seconds, got {t}"
            )));
        }
        opts.baseline = Baseline::Seconds(Duration::from_secs_f64(t));
    }
    if let Some(k) = a.baseline_sweeps {
        if k == 0 {
            return Err(Error::InvalidArgument("--baseline-sweeps must be at least 1".into()));
        }
        opts.baseline = Baseline::Sweeps(k);
    }
    if a.every.contains(&0) || a.inner_iterations == 0 || a.repeats == 0 {
        return Err(Error::InvalidArgument(
            "--every, --inner-iterations and --repeats take whole numbers of at least 1".into(),
        ));
    }
    if !a.experiments.is_empty() {
        opts.experiments = a
            .experiments
            .iter()
            .filter_map(|e| match e {
                ExperimentArg::Perturbed => Some(Experiment::Perturbed),
                ExperimentArg::Inner => Some(Experiment::InnerIterations),
                ExperimentArg::Inaccurate => Some(Experiment::Inaccurate),
                ExperimentArg::RedBlack => Some(Experiment::RedBlack),
                ExperimentArg::None => None,
            })
            .collect();
    }
    opts.every = a.every.clone();
    opts.inner_iterations = a.inner_iterations;
    opts.repeats = a.repeats;
    opts.seed = a.seed;
    std::fs::create_dir_all(&a.output).map_err(|e| Error::io(&a.output, e))?;
    let study = order_study(&opts, &mut |c, r| {
        eprintln!(
            "{:<22} {:<8} {:<9} {:>6} sweeps  COT {:.4} s  RT {:.4} s  TT {:.4} s{}",
            c.name,
            r.scheme,
            r.strategy,
            r.sweeps,
            r.cot_median(),
            r.rt_median(),
            r.tt_median(),
            if r.reached { "" } else { "  (target not reached)" }
        );
    })?;
    let mut files = vec![
        ("order-study.md".to_string(), study.to_markdown()),
        ("order-study.csv".to_string(), study.to_csv()),
        ("order-study-runs.csv".to_string(), study.runs_csv()),
        ("order-study-curves.csv".to_string(), study.curves_csv()),
    ];
    files.extend(study.figures());
    for (name, text) in &files {
        io::write_atomic(&a.output.join(name), |w| Ok(w.write_all(text.as_bytes())?))?;
    }
    println!(
        "{} cases, {} rows of {} repeats; wrote {} files to {}",
        study.cases.len(),
        study.rows.len(),
        study.repeats,
        files.len(),
        a.output.display()
    );
    Ok(())
}

pub fn newton_bcd(a: &NewtonStudyArgs) -> Result<()> {
    let mut opts = if a.quick {
        NewtonStudyOptions::quick()
    } else {
        NewtonStudyOptions::full()
    };
    opts.seed = a.seed;
    std::fs::create_dir_all(&a.output).map_err(|e| Error::io(&a.output, e))?;
    let t = |v: Option<f64>| v.map_or("-".into(), |s| format!("{s:.3}"));
    let study = newton_study(&opts, a.quick, &mut |c| {
        let cross = match &c.crossing {
            Crossing::At(p) => format!("crossover {:.3} s at {:.1}%", p.seconds, p.improvement_percent),
            Crossing::NewtonAhead => "Newton never behind".into(),
            Crossing::Never => "no crossover".into(),
        };
        eprintln!(
            "{:<16} {:>7} V  Newton {:>3} it T50 {} T100 {}  BCD {:>4} it T50 {} T100 {}  {cross}",
            c.name,
            c.vertices,
            c.newton.iterations,
            t(c.newton.t50),
            t(c.newton.t100),
            c.bcd.iterations,
            t(c.bcd.t50),
            t(c.bcd.t100)
        );
    })?;
    let mut files = vec![
        ("newton-study.md".to_string(), study.to_markdown()),
        ("newton-study.csv".to_string(), study.to_csv()),
        ("ratios.csv".to_string(), study.ratios_csv()),
    ];
    files.extend(study.figures());
    for (name, text) in &files {
        io::write_atomic(&a.output.join(name), |w| Ok(w.write_all(text.as_bytes())?))?;
    }
    println!(
        "{} cases in {:.1} s; wrote {} files to {}",
        study.cases.len(),
        study.seconds,
        files.len(),
        a.output.display()
    );
    Ok(())
}
