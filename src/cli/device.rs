//! The command line's arguments as the library's [`Smoother`] settings, and
//! the library's errors in the command line's words. Every check and default
//! lives in the library; this only translates.

use super::boundary::BoundaryArgs;
use super::{GpuArgs, ObjectiveArgs, SolverArgs, StopArgs};
use meshsmooth::{DeviceChoice, Error, Result, Smoother};
use std::collections::BTreeSet;
use std::path::Path;

impl StopArgs {
    fn fill(&self, s: &mut Smoother) {
        s.tol = self.tol;
        s.tol_x = self.tol_x;
        s.max_iter = self.max_iter;
        s.time_limit = self.time_limit;
        s.target_objective = self.target_objective;
    }
}

impl GpuArgs {
    fn fill(&self, s: &mut Smoother) {
        s.precision = self.precision;
        s.adapter = self.adapter.clone();
    }
}

impl ObjectiveArgs {
    fn fill(&self, s: &mut Smoother) {
        s.metric = self.metric;
        s.template = self.template;
        s.reference = self.reference.clone();
        s.target = self.target.clone().unwrap_or_else(|| "auto".into());
        s.order = self.order;
        s.order_seed = self.order_seed;
        s.reorder_every = self.reorder_every;
        s.inner_iterations = self.inner_iterations;
    }
}

impl BoundaryArgs {
    fn fill(&self, s: &mut Smoother) {
        s.boundary = self.boundary;
        s.feature_angle = self.feature_angle;
        s.surface = self.surface.clone();
        s.fix_groups = self.fix_group.clone();
        s.free_groups = self.free_group.clone();
        s.fixed_arrays = self.fixed_array.clone();
        s.fixed_files = self.fixed_file.clone();
    }
}

/// The settings of `compare` and `rezone`, which have no boundary rules.
pub fn settings(
    device: DeviceChoice,
    gpu: &GpuArgs,
    stop: &StopArgs,
    objective: Option<&ObjectiveArgs>,
) -> Result<Smoother> {
    let mut s = Smoother::default();
    s.device = device;
    gpu.fill(&mut s);
    stop.fill(&mut s);
    if let Some(o) = objective {
        o.fill(&mut s);
    }
    s.validate()?;
    Ok(s)
}

impl SolverArgs {
    /// The settings of `smooth`, `untangle` and `demo`: a `--config` file's,
    /// with the options given on the command line over them.
    pub fn smoother(&self, untangle: bool, keep_partial: bool) -> Result<Smoother> {
        let mut s = Smoother::default();
        s.method = self.method;
        s.device = self.device;
        self.gpu.fill(&mut s);
        self.stop.fill(&mut s);
        self.objective.fill(&mut s);
        self.boundary.fill(&mut s);
        s.negative_curvature = self.negative_curvature;
        s.preconditioner = self.preconditioner;
        s.inversion_fraction = self.inversion_fraction;
        s.start_sweeps = self.start_sweeps;
        s.untangle = untangle;
        s.keep_partial = keep_partial;
        if let Some(path) = &self.config {
            s = over_file(path, &s, &self.given)?;
        }
        s.validate()?;
        Ok(s)
    }
}

/// `file`'s settings with those of `cli` whose options were given (`given`:
/// the clap ids of the arguments on the command line).
fn over_file(file: &Path, cli: &Smoother, given: &BTreeSet<String>) -> Result<Smoother> {
    let base = Smoother::from_file(file)?;
    let to_map = |s: &Smoother| match serde_json::to_value(s).expect("settings serialise") {
        serde_json::Value::Object(m) => m,
        _ => unreachable!("settings serialise as an object"),
    };
    let mut merged = to_map(&base);
    for (key, value) in to_map(cli) {
        if given.contains(arg_id(&key)) {
            merged.insert(key, value);
        }
    }
    let mut s: Smoother = serde_json::from_value(serde_json::Value::Object(merged))
        .map_err(|e| Error::InvalidArgument(format!("{}: {e}", file.display())))?;
    s.reference_mesh = base.reference_mesh;
    Ok(s)
}

/// The clap id of the argument that sets the settings key `key`.
fn arg_id(key: &str) -> &str {
    match key {
        "fix_groups" => "fix_group",
        "free_groups" => "free_group",
        "fixed_arrays" => "fixed_array",
        "fixed_files" => "fixed_file",
        "untangle" => "no_untangle",
        "keep_partial" => "save_partial",
        k => k,
    }
}

/// The flag that sets the settings key `option`.
pub fn flag(option: &str) -> String {
    format!("--{}", arg_id(option).replace('_', "-"))
}

/// An error as the command line says it: options by their flags, and how to
/// get past a tangled input.
pub fn words(e: &Error) -> String {
    match e {
        Error::InvalidOption { option, message } => format!("invalid option {}: {message}", flag(option)),
        Error::Inverted { .. } => format!("{e} (meshsmooth untangle, or smooth without --no-untangle)"),
        Error::Parse { msg, .. } if msg.contains("must be untangled first") => {
            format!("{e} (meshsmooth untangle, or smooth without --no-untangle)")
        }
        _ => flagged(&e.to_string()),
    }
}

/// `message` with the settings that library messages quote by key and value
/// (`` `partitioner pieces` ``) as the flags that set them (`--partitioner
/// pieces`). Only a quoted settings key is taken for one, so other quoted
/// words stay as they are.
pub fn flagged(message: &str) -> String {
    let keys = match serde_json::to_value(Smoother::default()).expect("settings serialise") {
        serde_json::Value::Object(m) => m,
        _ => unreachable!("settings serialise as an object"),
    };
    // the run's settings kept outside the Smoother (the cluster's)
    let is_key = |k: &str| k == "partitioner" || keys.contains_key(k);
    let mut out = String::with_capacity(message.len());
    let mut rest = message;
    while let Some(open) = rest.find('`') {
        let Some(len) = rest[open + 1..].find('`') else {
            break;
        };
        let quoted = &rest[open + 1..open + 1 + len];
        let key = quoted.split(' ').next().unwrap_or_default();
        out.push_str(&rest[..open]);
        if is_key(key) {
            out.push_str(&flag(key));
            out.push_str(&quoted[key.len()..]);
        } else {
            out.push_str(&rest[open..open + len + 2]);
        }
        rest = &rest[open + len + 2..];
    }
    out.push_str(rest);
    out
}
