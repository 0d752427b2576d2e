//! A paper's qualitative finding checked case by case, as the studies report
//! them: how many cases bear it out and a verdict, so that a finding our
//! meshes do not reproduce is said, not hidden.

use serde::Serialize;

#[derive(Clone, Debug, Default, Serialize)]
pub struct Finding {
    pub claim: &'static str,
    /// Cases that bear it out, of how many. Where a finding compares timed
    /// runs, a case bears it out only when a rank test over the repeats says
    /// so (see `stats`).
    pub holds: usize,
    pub of: usize,
    /// Cases that the test says go the other way (0 where there is no test).
    pub against: usize,
    /// The run's numbers behind the count ("lead 2.1, 2.8, 3.5"), or empty.
    pub numbers: String,
    /// Why it may not hold here, said when it does not; may carry the run's
    /// own numbers for that cause.
    pub cause: String,
}

impl Finding {
    /// "reproduced" (every case), "in part" (some), "not reproduced" (none)
    /// or "not measured" (no case: the run lacks what the finding needs).
    pub fn verdict(&self) -> &'static str {
        match self.holds {
            _ if self.of == 0 => "not measured",
            0 => "not reproduced",
            h if h == self.of => "reproduced",
            _ => "in part",
        }
    }
}

/// The "## Findings" section of a study's Markdown: the verdict in the third
/// column, then the numbers and, for a finding that does not hold in every
/// case, its likely cause.
pub fn markdown(intro: &str, findings: &[Finding]) -> String {
    let mut s = format!(
        "\n## Findings\n\n{intro}\n\n| finding | cases that bear it out | verdict | numbers | likely cause where it fails |\n|---|---:|---|---|---|\n"
    );
    for f in findings {
        let cause = if f.holds == f.of { "" } else { f.cause.as_str() };
        s.push_str(&format!(
            "| {} | {} of {} | {} | {} | {cause} |\n",
            f.claim,
            f.holds,
            f.of,
            f.verdict(),
            f.numbers
        ));
    }
    s
}
