//! Source election: one compass, one true heading, and only an `HDT` from
//! an independent talker.

use std::collections::BTreeMap;

use super::importer::Kept;
use super::{bump, NmeaReport, MAGNETIC_COMPASS_TALKER, REFERENCE_TALKERS};

/// Keeps the heading sentences of one source (talker and type) among
/// `kinds`: the one with the most; the others' count and names.
pub(super) fn one_source(kept: &mut Vec<Kept>, kinds: &[&str]) -> (Option<String>, usize, Vec<String>) {
    let mut counts: Vec<(String, usize)> = Vec::new();
    for k in kept.iter().filter(|k| kinds.contains(&k.sentence.kind())) {
        let key = format!("{}{}", k.talker, k.sentence.kind());
        match counts.iter_mut().find(|(n, _)| *n == key) {
            Some((_, c)) => *c += 1,
            None => counts.push((key, 1)),
        }
    }
    // The most sentences; the first seen on a tie.
    let Some(best) = counts.iter().enumerate().max_by_key(|(i, (_, c))| (*c, usize::MAX - i)).map(|(_, (n, _))| n.clone()) else {
        return (None, 0, Vec::new());
    };
    let before = kept.len();
    kept.retain(|k| !kinds.contains(&k.sentence.kind()) || format!("{}{}", k.talker, k.sentence.kind()) == best);
    let others = counts.into_iter().filter(|(n, _)| *n != best).map(|(n, c)| format!("{n} ({c})")).collect();
    (Some(best), before - kept.len(), others)
}

/// Keeps only the `HDT` that may be a reference: of a talker in
/// [`REFERENCE_TALKERS`] or the one named. The compass's own (its talker's,
/// or `HC`'s) and the others are counted and removed; the notes say which.
pub(super) fn independent_hdt_only(kept: &mut Vec<Kept>, compass_talker: &str, named: Option<&str>, report: &mut NmeaReport) -> Vec<String> {
    let mut own: BTreeMap<String, usize> = BTreeMap::new();
    let mut unplaced: BTreeMap<String, usize> = BTreeMap::new();
    kept.retain(|k| {
        if k.sentence.kind() != "HDT" {
            return true;
        }
        let t = k.talker.as_str();
        let source = format!("{t}HDT");
        if t == compass_talker || t == MAGNETIC_COMPASS_TALKER {
            bump(&mut own, &source);
            false
        } else if REFERENCE_TALKERS.contains(&t) || named == Some(t) {
            true
        } else {
            bump(&mut unplaced, &source);
            false
        }
    });
    let list = |m: &BTreeMap<String, usize>| m.iter().map(|(s, n)| format!("{s} ({n})")).collect::<Vec<_>>().join(", ");
    let mut notes = Vec::new();
    report.compass_true_headings = own.values().sum();
    if !own.is_empty() {
        notes.push(format!(
            "{} is the compass's own true heading (its heading plus the variation, already in compass_heading_deg and variation_deg): not a reference, not used",
            list(&own)
        ));
    }
    report.unplaced_true_headings = unplaced.values().sum();
    report.unplaced_true_heading_sources = unplaced.keys().cloned().collect();
    if !unplaced.is_empty() {
        notes.push(format!(
            "{}: a true heading from a talker that is neither a GNSS receiver's nor a gyrocompass's (it may relay the compass's own heading): not used as the reference; if it is an independent instrument, name its talker as the reference talker",
            list(&unplaced)
        ));
    }
    notes
}
