//! Iteration display: a progress bar on a terminal, a sparse iteration log on stdout.

use indicatif::{ProgressBar, ProgressStyle};
use meshsmooth::solve::Record;
use std::io::IsTerminal;

pub struct Progress {
    bar: Option<ProgressBar>,
    log: bool,
}

impl Progress {
    pub fn new(max_iter: usize, log: bool) -> Self {
        let bar = std::io::stderr().is_terminal().then(|| {
            let bar = ProgressBar::new(max_iter as u64);
            bar.set_style(
                ProgressStyle::with_template("{spinner} [{elapsed_precise}] {bar:30} {pos}/{len} sweeps  {msg}")
                    .expect("valid template"),
            );
            bar
        });
        if log {
            println!(
                "{:>6} {:>10} {:>20} {:>12}",
                "iter", "seconds", "objective F", "|grad F|"
            );
        }
        Progress { bar, log }
    }

    /// Logs the `logged` iterations; the last one is printed by `finish`.
    pub fn update(&mut self, r: &Record) -> bool {
        if self.log && logged(r.iteration) {
            self.line(r);
        }
        if let Some(bar) = &self.bar {
            bar.set_position(r.iteration as u64);
            bar.set_message(format!("F = {:.8}  |grad F| = {:.3e}", r.objective, r.grad_norm));
        }
        true
    }

    pub fn finish(&mut self, last: Option<&Record>) {
        if let Some(bar) = self.bar.take() {
            bar.finish_and_clear();
        }
        if let Some(r) = last
            && self.log
            && !logged(r.iteration)
        {
            self.line(r);
        }
    }

    fn line(&self, r: &Record) {
        let msg = format!(
            "{:>6} {:>10.3} {:>20.12} {:>12.4e}",
            r.iteration, r.seconds, r.objective, r.grad_norm
        );
        match &self.bar {
            Some(bar) => bar.println(msg),
            None => println!("{msg}"),
        }
    }
}

/// Iterations 0-10, every 10th to 100, every 100th after.
fn logged(i: usize) -> bool {
    i <= 10 || (i <= 100 && i.is_multiple_of(10)) || i.is_multiple_of(100)
}
