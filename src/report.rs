//! Quality reports.
