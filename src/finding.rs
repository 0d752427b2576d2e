//! A paper's qualitative finding checked case by case, as the studies report
//! them: how many cases bear it out and a verdict, so that a finding our
//! meshes do not reproduce is said, not hidden.

use serde::Serialize;

#[derive(Clone, Debug, Serialize)]
pub struct Finding {
    pub claim: &'static str,
    /// Cases that bear it out, of how many.
    pub holds: usize,
    pub of: usize,
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
    let mut s = format!("\n## Findings\n\n{intro}\n\n| finding | cases that bear it out | verdict |\n|---|---:|---|\n");
    for f in findings {
        s.push_str(&format!(
            "| {} | {} of {} | {} |\n",
            f.claim,
            f.holds,
            f.of,
            f.verdict()
        ));
    }
    s
}
