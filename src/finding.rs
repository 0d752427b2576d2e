//! A paper's qualitative finding checked case by case, as the studies report
//! them: how many cases bear it out and a verdict, so that a finding our
//! meshes do not reproduce is said, not hidden.

use serde::Serialize;

#[derive(Clone, Debug, Default, Serialize)]
pub struct Finding {
    pub claim: &'static str,
    /// Cases that bear it out, of how many.
    pub holds: usize,
    pub of: usize,
    /// The run's numbers behind the count ("lead 2.1, 2.8, 3.5"), or empty.
    pub numbers: String,
    /// Why it may not hold here, said when it does not.
    pub cause: &'static str,
}

impl Finding {
    /// "reproduced" (every case), "in part" (some) or "not reproduced" (none).
    pub fn verdict(&self) -> &'static str {
        match self.holds {
            0 => "not reproduced",
            h if h == self.of => "reproduced",
            _ => "in part",
        }
    }
}

/// The "## Findings" section of a study's Markdown.
pub fn markdown(intro: &str, findings: &[Finding]) -> String {
    let mut s = format!(
        "\n## Findings\n\n{intro}\n\n| finding | cases that bear it out | verdict | numbers | likely cause where it fails |\n|---|---:|---|---|---|\n"
    );
    for f in findings {
        let cause = if f.holds == f.of { "" } else { f.cause };
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
