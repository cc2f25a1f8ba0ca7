//! "Recalibrate" and its evidence: the one rule that turns a run's
//! per-sample integrity into "the calibration does not fit this vehicle any
//! more", for the session (its validation run, applied by the board's own
//! code on the host) and `magcal log` (the board's streamed states). A leaf:
//! it imports only the typed results ([`crate::doc::results`]).
//!
//! * [`IntegrityCounts`]: what the rule reads — samples per state, the
//!   longest stretches, whether the on-line hard iron was applied;
//! * [`IntegrityTally`]: those counts accumulated sample by sample from a
//!   stream of states on a clock;
//! * [`recalibrate_evidence`] (the rule) and [`recalibrate_text`] (the line).

use calib_core::integrity::IntegrityState;
use serde::{Deserialize, Serialize};

use crate::doc::results::RecalibrateEvidence;

/// Share of a run judged `cal_invalid` above which "recalibrate" is said:
/// `cal_invalid` needs a misfit sustained for seconds, so a pier or hull
/// passed at a few metres gives a short stretch of it; a tenth of the run
/// is no passing object.
pub const RECALIBRATE_CAL_INVALID_FRACTION: f64 = 0.10;

/// Samples in each integrity state, one count per state of
/// [`IntegrityState::ALL`]; in JSON an object keyed by the states' names,
/// in that order (`{"ok": …, "disturbed": …, …}`; a state missing reads
/// as 0, an unknown name is ignored).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct StateCounts {
    per_state: [u64; IntegrityState::COUNT],
}

impl StateCounts {
    /// One more sample in `state`.
    pub fn add(&mut self, state: IntegrityState) {
        self.per_state[state.index()] += 1;
    }

    /// The samples in `state`.
    pub fn of(&self, state: IntegrityState) -> u64 {
        self.per_state[state.index()]
    }

    /// All samples.
    pub fn total(&self) -> u64 {
        self.per_state.iter().sum()
    }

    /// The counts of `(state, samples)` pairs (the states not given: 0).
    pub fn from_pairs(pairs: &[(IntegrityState, u64)]) -> Self {
        let mut c = Self::default();
        for &(s, n) in pairs {
            c.per_state[s.index()] = n;
        }
        c
    }
}

impl Serialize for StateCounts {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut m = serializer.serialize_map(Some(IntegrityState::COUNT))?;
        for s in IntegrityState::ALL {
            m.serialize_entry(s.name(), &self.of(s))?;
        }
        m.end()
    }
}

impl<'de> Deserialize<'de> for StateCounts {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let by_name = std::collections::BTreeMap::<String, u64>::deserialize(deserializer)?;
        let mut c = Self::default();
        for (name, n) in by_name {
            if let Some(s) = IntegrityState::from_name(&name) {
                c.per_state[s.index()] = n;
            }
        }
        Ok(c)
    }
}

/// What a run's per-sample integrity amounted to: what
/// [`recalibrate_evidence`] reads.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct IntegrityCounts {
    /// Samples in each state.
    pub states: StateCounts,
    /// Longest run of samples not `ok` (disturbed or calibration invalid), s.
    pub longest_disturbance_s: f64,
    /// Longest run of samples `cal_invalid`, s (`None` where the run's
    /// clock is not known per sample).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub longest_cal_invalid_s: Option<f64>,
    /// The on-line hard-iron estimate was applied at some point (`None`
    /// when that could not be read, e.g. the board's `Health` at the end).
    pub hard_iron_applied: Option<bool>,
    /// The on-line hard-iron estimate at the end, nT (when there is one).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hard_iron_nt: Option<[f64; 3]>,
}

/// [`IntegrityCounts`] accumulated from a stream of states on a clock, the
/// stretches measured as calib-core's `Health` measures its longest
/// disturbance: each sample of a run adds the time since the one before.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct IntegrityTally {
    counts: IntegrityCounts,
    last_t_s: Option<f64>,
    disturbance_s: f64,
    cal_invalid_s: f64,
}

impl IntegrityTally {
    /// One sample judged `state` at `t_s` (s, any origin, increasing).
    pub fn push(&mut self, state: IntegrityState, t_s: f64) {
        let dt_s = self.last_t_s.map_or(0.0, |l| t_s - l);
        let dt_s = if dt_s.is_finite() && dt_s > 0.0 { dt_s } else { 0.0 };
        self.last_t_s = Some(t_s);
        self.counts.states.add(state);
        let c = &mut self.counts;
        if state.is_disturbance() {
            self.disturbance_s += dt_s;
            c.longest_disturbance_s = c.longest_disturbance_s.max(self.disturbance_s);
        } else {
            self.disturbance_s = 0.0;
        }
        if state == IntegrityState::CalInvalid {
            self.cal_invalid_s += dt_s;
            c.longest_cal_invalid_s = Some(c.longest_cal_invalid_s.unwrap_or(0.0).max(self.cal_invalid_s));
        } else {
            self.cal_invalid_s = 0.0;
        }
    }

    /// The counts so far (the hard-iron fields as set with
    /// [`IntegrityTally::set_hard_iron`]; unknown until then).
    pub fn counts(&self) -> IntegrityCounts {
        self.counts
    }

    /// What the board (or the host's run) says of the on-line hard iron.
    pub fn set_hard_iron(&mut self, applied: Option<bool>, estimate_nt: Option<[f64; 3]>) {
        self.counts.hard_iron_applied = applied;
        self.counts.hard_iron_nt = estimate_nt;
    }
}

/// "Recalibrate" when more than `max_cal_invalid_fraction` of the samples
/// are `cal_invalid` or the on-line hard iron was applied, with the
/// evidence; `None` otherwise (and for an empty run). Disturbed samples (a
/// passing object) are not evidence.
pub fn recalibrate_evidence(c: &IntegrityCounts, max_cal_invalid_fraction: f64) -> Option<RecalibrateEvidence> {
    let rows = usize::try_from(c.states.total()).unwrap_or(usize::MAX);
    let cal_invalid_rows = usize::try_from(c.states.of(IntegrityState::CalInvalid)).unwrap_or(usize::MAX);
    let cal_invalid_fraction = if rows > 0 { cal_invalid_rows as f64 / rows as f64 } else { 0.0 };
    let hard_iron_applied = c.hard_iron_applied == Some(true);
    (rows > 0 && (cal_invalid_fraction > max_cal_invalid_fraction || hard_iron_applied)).then_some(RecalibrateEvidence {
        rows,
        cal_invalid_rows,
        cal_invalid_fraction,
        hard_iron_applied,
        hard_iron_nt: c.hard_iron_nt,
        longest_disturbance_s: c.longest_disturbance_s,
        longest_cal_invalid_s: c.longest_cal_invalid_s,
    })
}

/// The printed line: "recalibrate" and why; `rows_are` names the samples
/// ("validation rows", "logged samples").
pub fn recalibrate_text(e: &RecalibrateEvidence, rows_are: &str) -> String {
    let mut why = vec![format!("{} of {} {rows_are} ({:.1} %) cal_invalid", e.cal_invalid_rows, e.rows, 100.0 * e.cal_invalid_fraction)];
    if let Some(s) = e.longest_cal_invalid_s {
        why.push(format!("longest cal_invalid stretch {s:.1} s"));
    }
    if e.hard_iron_applied {
        why.push(match e.hard_iron_nt {
            Some(h) => format!("the on-line hard iron was applied ({:.0}, {:.0}, {:.0} nT)", h[0], h[1], h[2]),
            None => "the on-line hard iron was applied".into(),
        });
    }
    why.push(format!("longest disturbance {:.1} s", e.longest_disturbance_s));
    format!("RECALIBRATE: the calibration does not fit this vehicle any more: {}", why.join("; "))
}

/// The counts in words: samples per state, the longest stretches, the
/// on-line hard iron ("1520 ok, 0 disturbed, 100 cal_invalid, 0
/// no_attitude, 0 unjudged; longest disturbance 1.0 s, longest cal_invalid
/// 1.0 s; no on-line hard-iron estimate"), the states in
/// [`IntegrityState::ALL`]'s order.
pub fn integrity_text(c: &IntegrityCounts) -> String {
    let n = &c.states;
    let cal_invalid = c.longest_cal_invalid_s.map_or(String::new(), |t| format!(", longest cal_invalid {t:.1} s"));
    let hard_iron = match (c.hard_iron_applied, c.hard_iron_nt) {
        (None, _) => "the on-line hard iron not read".to_string(),
        (Some(a), Some(h)) => format!("on-line hard iron ({:.0}, {:.0}, {:.0}) nT, {}", h[0], h[1], h[2], if a { "applied" } else { "not applied" }),
        (Some(true), None) => "the on-line hard iron applied".to_string(),
        (Some(false), None) => "no on-line hard-iron estimate".to_string(),
    };
    let states: Vec<String> = IntegrityState::ALL.iter().map(|&s| format!("{} {}", n.of(s), s.name())).collect();
    format!("{}; longest disturbance {:.1} s{cal_invalid}; {hard_iron}", states.join(", "), c.longest_disturbance_s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use IntegrityState::{CalInvalid, Disturbed, NoAttitude, Ok};

    /// Stretches on a 10 Hz clock, counted by hand: ok 0.0–0.9 s, disturbed
    /// 1.0–1.4, cal_invalid 1.5–2.4, no_attitude 2.5, cal_invalid 2.6–2.8.
    /// Each sample of a run adds its 0.1 s step: the disturbance run is 15
    /// samples (1.5 s), the longest cal_invalid stretch 10 (1.0 s).
    #[test]
    fn the_tally_counts_states_and_measures_stretches_on_the_clock() {
        let mut t = IntegrityTally::default();
        let states: Vec<IntegrityState> = [(Ok, 10), (Disturbed, 5), (CalInvalid, 10), (NoAttitude, 1), (CalInvalid, 3)].iter().flat_map(|&(s, n)| std::iter::repeat_n(s, n)).collect();
        for (i, s) in states.iter().enumerate() {
            t.push(*s, i as f64 * 0.1);
        }
        let c = t.counts();
        assert_eq!(c.states, StateCounts::from_pairs(&[(Ok, 10), (Disturbed, 5), (CalInvalid, 13), (NoAttitude, 1)]));
        assert_eq!(c.states.total(), 29);
        assert!((c.longest_disturbance_s - 1.5).abs() < 1e-9, "{c:?}");
        assert!((c.longest_cal_invalid_s.unwrap() - 1.0).abs() < 1e-9, "{c:?}");
        assert_eq!(c.hard_iron_applied, None);
        // 13 of 29 cal_invalid (45 %): recalibrate, with the stretch.
        let e = recalibrate_evidence(&c, RECALIBRATE_CAL_INVALID_FRACTION).expect("45 % cal_invalid");
        assert_eq!((e.rows, e.cal_invalid_rows, e.hard_iron_applied), (29, 13, false));
        let text = recalibrate_text(&e, "logged samples");
        assert!(text.contains("13 of 29 logged samples (44.8 %) cal_invalid; longest cal_invalid stretch 1.0 s") && !text.contains("hard iron"), "{text}");
    }

    /// The counts' JSON is the object the documents have always carried
    /// (`docs/INTERFACES.md`: the states' names in order), both ways; a
    /// document from before `unjudged` reads it as 0.
    #[test]
    fn the_counts_are_written_and_read_by_the_states_names() {
        let c = StateCounts::from_pairs(&[(Ok, 10), (Disturbed, 5), (CalInvalid, 13), (NoAttitude, 1), (IntegrityState::Unjudged, 2)]);
        let text = serde_json::to_string(&c).unwrap();
        assert_eq!(text, r#"{"ok":10,"disturbed":5,"cal_invalid":13,"no_attitude":1,"unjudged":2}"#);
        assert_eq!(serde_json::from_str::<StateCounts>(&text).unwrap(), c);
        let old: StateCounts = serde_json::from_str(r#"{"ok":3,"disturbed":0,"cal_invalid":1,"no_attitude":0}"#).unwrap();
        assert_eq!((old.of(Ok), old.of(CalInvalid), old.of(IntegrityState::Unjudged), old.total()), (3, 1, 0, 4));
    }

    /// A hard iron applied is evidence when known to be; unknown is not.
    #[test]
    fn the_hard_iron_counts_only_when_known_applied() {
        let mut t = IntegrityTally::default();
        for i in 0..100 {
            t.push(Ok, f64::from(i));
        }
        assert_eq!(recalibrate_evidence(&t.counts(), 0.10), None);
        t.set_hard_iron(Some(false), Some([100.0, 0.0, 0.0]));
        assert_eq!(recalibrate_evidence(&t.counts(), 0.10), None);
        t.set_hard_iron(Some(true), Some([100.0, -20.0, 5.0]));
        let e = recalibrate_evidence(&t.counts(), 0.10).expect("applied");
        assert!(recalibrate_text(&e, "logged samples").contains("the on-line hard iron was applied (100, -20, 5 nT)"));
        assert_eq!(recalibrate_evidence(&IntegrityCounts { hard_iron_applied: Some(true), ..Default::default() }, 0.10), None, "an empty run says nothing");
    }
}
