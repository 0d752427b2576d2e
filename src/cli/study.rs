//! `meshsmooth study order` and `meshsmooth study newton-bcd`: the papers'
//! studies, written as Markdown, CSV (and SVG).

use super::{NewtonStudyArgs, OrderStudyArgs};
use meshsmooth::newton_study::{Crossing, NewtonStudyOptions, newton_study};
use meshsmooth::order_study::{OrderStudyOptions, order_study};
use meshsmooth::{Error, Result, io};
use std::time::Duration;

pub fn order(a: &OrderStudyArgs) -> Result<()> {
    let mut opts = if a.quick {
        OrderStudyOptions::quick()
    } else {
        OrderStudyOptions {
            free: 20000,
            baseline: Duration::from_secs(10),
            ..OrderStudyOptions::quick()
        }
    };
    if let Some(k) = a.kind {
        opts.kind = k;
    }
    if let Some(n) = a.free {
        opts.free = n;
    }
    if let Some(t) = a.baseline {
        if !(t.is_finite() && t > 0.0) {
            return Err(Error::InvalidArgument(format!(
                "--baseline must be a positive number of seconds, got {t}"
            )));
        }
        opts.baseline = Duration::from_secs_f64(t);
    }
    if a.every.contains(&0) || a.inner_iterations == 0 {
        return Err(Error::InvalidArgument(
            "--every and --inner-iterations take whole numbers of at least 1".into(),
        ));
    }
    opts.every = a.every.clone();
    opts.inner_iterations = a.inner_iterations;
    opts.seed = a.seed;
    std::fs::create_dir_all(&a.output).map_err(|e| Error::io(&a.output, e))?;
    let study = order_study(&opts, &mut |r| {
        eprintln!(
            "{:<8} {:<9} {:>6} sweeps  COT {:.3} s  RT {:.4} s  TT {:.3} s{}",
            r.scheme,
            r.strategy,
            r.sweeps,
            r.cot,
            r.rt,
            r.tt,
            if r.reached { "" } else { "  (target not reached)" }
        );
    })?;
    let md = a.output.join("order-study.md");
    let csv = a.output.join("order-study.csv");
    io::write_atomic(&md, |w| Ok(w.write_all(study.to_markdown().as_bytes())?))?;
    io::write_atomic(&csv, |w| Ok(w.write_all(study.to_csv().as_bytes())?))?;
    println!(
        "target F {:.8} (baseline N, {:.3} s); wrote {} and {}",
        study.target,
        study.baseline_seconds,
        md.display(),
        csv.display()
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
