//! The bench's targets as checks: each section states its targets
//! ([`Target`]) from the numbers it computed, and [`check`] turns them into
//! failures ([`TargetMiss`]) that name the section, the figure and the
//! number. `cargo xtask bench` checks them after writing its results;
//! `cargo xtask bench --ci` runs the sections at CI sizes ([`Sizes::CI`])
//! and only checks, one libtest-style line per target, so that
//! `cargo xtask test` counts them as a suite.
//!
//! A target the project states but does not meet today is *held*: the
//! check fails when the figure gets worse than what was measured, and the
//! line says the stated target is missed. A figure that is missing (a
//! section that failed, a NaN) fails.

use std::fmt;

/// Which way a figure must go.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Bound {
    /// The figure is at most this.
    AtMost(f64),
    /// The figure is at least this.
    AtLeast(f64),
}

impl Bound {
    fn holds(self, v: f64) -> bool {
        match self {
            Bound::AtMost(l) => v <= l,
            Bound::AtLeast(l) => v >= l,
        }
    }
}

impl fmt::Display for Bound {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Bound::AtMost(l) => write!(f, "≤ {l}"),
            Bound::AtLeast(l) => write!(f, "≥ {l}"),
        }
    }
}

/// One stated target and the figure a section measured for it.
#[derive(Debug, Clone, PartialEq)]
pub struct Target {
    /// The bench section (`mcu`, `effects`, …).
    pub section: &'static str,
    /// The figure, in words with its unit.
    pub what: String,
    /// What was measured (`None`: the section did not produce it).
    pub value: Option<f64>,
    /// The stated target.
    pub bound: Bound,
    /// A stated target missed today: the bound the figure must keep (what
    /// was measured, so that it cannot get worse), and why it is missed.
    pub held: Option<(Bound, &'static str)>,
}

impl Target {
    /// A target that is met today.
    pub fn new(section: &'static str, what: impl Into<String>, value: Option<f64>, bound: Bound) -> Self {
        Target { section, what: what.into(), value: value.filter(|v| !v.is_nan()), bound, held: None }
    }

    /// A stated target missed today, held at `held` (why: `reason`).
    pub fn held(mut self, held: Bound, reason: &'static str) -> Self {
        self.held = Some((held, reason));
        self
    }

    /// The bound the check applies: the held one where the target is missed.
    fn applied(&self) -> Bound {
        self.held.map_or(self.bound, |(b, _)| b)
    }

    /// The failure, if the figure misses the bound the check applies.
    pub fn miss(&self) -> Option<TargetMiss> {
        let fails = self.value.is_none_or(|v| !self.applied().holds(v));
        fails.then(|| TargetMiss { section: self.section, what: self.what.clone(), value: self.value, bound: self.applied() })
    }
}

/// A figure that misses the bound its section's check applies.
#[derive(Debug, Clone, PartialEq)]
pub struct TargetMiss {
    /// The bench section.
    pub section: &'static str,
    /// The figure.
    pub what: String,
    /// What was measured (`None`: not measured).
    pub value: Option<f64>,
    /// The bound it misses.
    pub bound: Bound,
}

impl fmt::Display for TargetMiss {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.value {
            Some(v) => write!(f, "{}: {} is {v}, target {}", self.section, self.what, self.bound),
            None => write!(f, "{}: {} was not measured (target {})", self.section, self.what, self.bound),
        }
    }
}

/// How much of each section a run computes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sizes {
    /// Seeds of the effects section.
    pub effects_seeds: &'static [u64],
    /// The effects section's other chains (each model off, the paper's
    /// method, each effect alone); without them only the chain with every
    /// model on all five effects, which is what its targets are about.
    pub effects_other_chains: bool,
    /// Seeds of the varied-sites section.
    pub varied_seeds: &'static [u64],
    /// The varied-sites section's chain without the gradient and its
    /// leave-one-site-out choice of the prior (no target is about them).
    pub varied_choice: bool,
}

impl Sizes {
    /// What CI computes (`cargo xtask bench --ci`): every seed, only the
    /// chains and tunings the targets are about (about 50 CPU-s in the
    /// xtask binary's profile). The held bounds are the worst of these
    /// seeds, so a subset passed here for speed still holds them.
    pub const CI: Sizes = Sizes { effects_seeds: &super::effects::EFFECTS_SEEDS, effects_other_chains: false, varied_seeds: &super::varied::VARIED_SEEDS, varied_choice: false };
}

/// The misses among `targets`, and one libtest-style line per target
/// (`test SECTION: WHAT = VALUE (TARGET) ... ok|FAILED`).
pub fn check(targets: &[Target]) -> (Vec<String>, Vec<TargetMiss>) {
    let mut lines = Vec::new();
    let mut misses = Vec::new();
    for t in targets {
        let value = t.value.map_or("not measured".to_string(), |v| format!("{v:.4}"));
        let stated = match t.held {
            Some((held, why)) => format!("target {}, missed: {why}; held at {held}", t.bound),
            None => format!("target {}", t.bound),
        };
        let miss = t.miss();
        lines.push(format!("test {}: {} = {value} ({stated}) ... {}", t.section, t.what, if miss.is_some() { "FAILED" } else { "ok" }));
        misses.extend(miss);
    }
    (lines, misses)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_figure_past_its_target_fails_with_its_section_and_number() {
        let t = Target::new("mcu", "instructions per sample", Some(301.0), Bound::AtMost(300.0));
        let miss = t.miss().expect("301 > 300 fails");
        assert_eq!(miss.to_string(), "mcu: instructions per sample is 301, target ≤ 300");
        assert!(Target::new("mcu", "x", Some(300.0), Bound::AtMost(300.0)).miss().is_none());
        assert!(Target::new("s", "x", Some(0.5), Bound::AtLeast(0.6)).miss().is_some());
    }

    #[test]
    fn a_missing_or_nan_figure_fails() {
        assert!(Target::new("s", "x", None, Bound::AtMost(1.0)).miss().is_some());
        assert!(Target::new("s", "x", Some(f64::NAN), Bound::AtMost(1.0)).miss().is_some());
    }

    #[test]
    fn a_held_target_fails_only_when_the_figure_gets_worse_than_measured() {
        let t = |v| Target::new("effects", "heading", Some(v), Bound::AtMost(0.3)).held(Bound::AtMost(0.33), "two seeds");
        assert!(t(0.32).miss().is_none());
        assert_eq!(t(0.34).miss().map(|m| m.bound), Some(Bound::AtMost(0.33)));
        let (lines, misses) = check(&[t(0.32), t(0.34)]);
        assert_eq!(misses.len(), 1);
        assert!(lines[0].ends_with("... ok") && lines[1].ends_with("... FAILED"), "{lines:?}");
        assert!(lines[0].contains("target ≤ 0.3, missed: two seeds; held at ≤ 0.33"), "{lines:?}");
    }
}
