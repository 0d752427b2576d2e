//! Iteration display: a progress bar on a terminal, an iteration log on stdout.

use indicatif::{ProgressBar, ProgressStyle};
use meshsmooth::solve::Record;
use std::io::IsTerminal;
use std::time::{Duration, Instant};

/// Which iterations are logged on stdout.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Log {
    None,
    /// Iterations 0-10, every 10th to 100, every 100th after.
    Sparse,
    /// Only on long runs: an iteration at most every [`SLOW_EVERY`], so a
    /// log file shows a run that takes minutes is alive, and a short run
    /// prints nothing.
    Slow,
}

const SLOW_EVERY: Duration = Duration::from_secs(10);

pub struct Progress {
    bar: Option<ProgressBar>,
    log: Log,
    /// When the last line was logged (or the run began), for `Log::Slow`.
    last: Instant,
    header: bool,
}

impl Progress {
    pub fn new(max_iter: usize, log: Log) -> Self {
        let bar = std::io::stderr().is_terminal().then(|| {
            let bar = ProgressBar::new(max_iter as u64);
            bar.set_style(
                ProgressStyle::with_template("{spinner} [{elapsed_precise}] {bar:30} {pos}/{len} sweeps  {msg}")
                    .expect("valid template"),
            );
            bar
        });
        Progress {
            bar,
            log,
            last: Instant::now(),
            header: false,
        }
    }

    /// Logs the iterations `log` asks for; a sparse log's last one is printed by `finish`.
    pub fn update(&mut self, r: &Record) -> bool {
        let due = match self.log {
            Log::None => false,
            Log::Sparse => logged(r.iteration),
            // a terminal's bar shows the run is alive
            Log::Slow => self.bar.is_none() && self.last.elapsed() >= SLOW_EVERY,
        };
        if due {
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
            && self.log == Log::Sparse
            && !logged(r.iteration)
        {
            self.line(r);
        }
    }

    fn line(&mut self, r: &Record) {
        if !self.header {
            self.header = true;
            self.print(format!(
                "{:>6} {:>10} {:>20} {:>12}",
                "iter", "seconds", "objective F", "|grad F|"
            ));
        }
        self.last = Instant::now();
        let msg = format!(
            "{:>6} {:>10.3} {:>20.12} {:>12.4e}",
            r.iteration, r.seconds, r.objective, r.grad_norm
        );
        self.print(msg);
    }

    fn print(&self, msg: String) {
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
