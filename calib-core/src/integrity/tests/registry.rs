//! The states' registry held to [`IntegrityState::ALL`] (names, wire codes,
//! per-state arrays, the prose lists of the documents), and the one rule,
//! [`decide`], against its table written out by hand.

use super::*;
use std::path::{Path, PathBuf};
use std::string::String;
use std::vec::Vec;

/// The wire code of each state as published (`docs/INTERFACES.md`,
/// protocol versions 4–5; a new state is appended). Exhaustive: a state
/// missing here does not compile.
fn published_code(s: IntegrityState) -> u8 {
    match s {
        IntegrityState::Ok => 0,
        IntegrityState::Disturbed => 1,
        IntegrityState::CalInvalid => 2,
        IntegrityState::NoAttitude => 3,
        IntegrityState::Unjudged => 4,
    }
}

#[test]
fn every_state_is_in_all_once_with_a_name_and_a_wire_code_that_round_trip() {
    assert_eq!(IntegrityState::COUNT, IntegrityState::ALL.len());
    for (i, s) in IntegrityState::ALL.into_iter().enumerate() {
        // Listed in ALL at its published code, which is its index.
        assert_eq!(usize::from(published_code(s)), i, "{s:?}");
        assert_eq!(s.code(), published_code(s), "{s:?}");
        assert_eq!(s.index(), i, "{s:?}");
        assert_eq!(IntegrityState::from_code(s.code()), Some(s));
        // A word of CSV and JSON: lower case, underscores, unique.
        let n = s.name();
        assert!(!n.is_empty() && n.bytes().all(|b| b.is_ascii_lowercase() || b == b'_'), "{n}");
        assert_eq!(IntegrityState::from_name(n), Some(s));
        assert_eq!(IntegrityState::ALL.iter().filter(|t| t.name() == n).count(), 1, "{n}");
    }
    // Every published code names a state of ALL, and nothing past them.
    for code in 0..=u8::MAX {
        let listed = IntegrityState::ALL.iter().find(|s| published_code(**s) == code);
        assert_eq!(IntegrityState::from_code(code), listed.copied(), "{code}");
    }
    assert_eq!(IntegrityState::from_name("Ok"), None);
}

/// The evidence of a sample that passes everything, judged against a
/// reference inclination, without an on-line hard iron.
const FINE: Evidence = Evidence {
    field: true,
    attitude: true,
    judged: true,
    cal_invalid: false,
    disturbed: false,
    hard_iron: HardIronEvidence::NotApplied,
    independent_inclination: true,
};

/// [`decide`] against the rule of `docs/INTERFACES.md` ("Integrity"),
/// case by case: what the sample lacks first (no heading), then what makes
/// the calibration invalid, then a disturbance, then an unproven on-line
/// hard iron, then a dip judged only against itself.
#[test]
fn the_verdict_follows_its_table() {
    use HardIronEvidence::{Confirmed, NotApplied, Refuted, Unconfirmed};
    use IntegrityState::{CalInvalid, Disturbed, NoAttitude, Ok, Unjudged};
    let e = FINE;
    let everything_wrong = Evidence {
        judged: false,
        cal_invalid: true,
        disturbed: true,
        hard_iron: Refuted,
        independent_inclination: false,
        ..e
    };
    let table: [(Evidence, IntegrityState); 17] = [
        (e, Ok),
        (Evidence { independent_inclination: false, ..e }, Unjudged),
        (Evidence { field: false, ..e }, NoAttitude),
        (Evidence { attitude: false, ..e }, NoAttitude),
        (Evidence { field: false, ..everything_wrong }, NoAttitude),
        (Evidence { attitude: false, ..everything_wrong }, NoAttitude),
        // The board without a reference: a heading never trusted.
        (Evidence::without_monitor(true, true), CalInvalid),
        (Evidence::without_monitor(true, false), NoAttitude),
        (Evidence::without_monitor(false, true), NoAttitude),
        (Evidence { cal_invalid: true, disturbed: true, ..e }, CalInvalid),
        (Evidence { disturbed: true, ..e }, Disturbed),
        (Evidence { disturbed: true, independent_inclination: false, ..e }, Disturbed),
        // The gyro refuting the estimate outranks a disturbance; an
        // estimate merely unconfirmed does not.
        (Evidence { disturbed: true, hard_iron: Refuted, ..e }, CalInvalid),
        (Evidence { disturbed: true, hard_iron: Unconfirmed, ..e }, Disturbed),
        (Evidence { hard_iron: Unconfirmed, independent_inclination: false, ..e }, CalInvalid),
        (Evidence { hard_iron: Confirmed, ..e }, Ok),
        (Evidence { hard_iron: Confirmed, independent_inclination: false, ..e }, Unjudged),
    ];
    for (k, (evidence, want)) in table.iter().enumerate() {
        assert_eq!(decide(evidence), *want, "row {k}: {evidence:?}");
    }
    assert_eq!(decide(&Evidence { hard_iron: NotApplied, ..e }), Ok);
    // The heading's own σ: a judged heading whose field passed.
    assert!(e.fits() && Evidence { hard_iron: Unconfirmed, independent_inclination: false, ..e }.fits());
    for other in [
        Evidence { disturbed: true, ..e },
        Evidence { cal_invalid: true, ..e },
        Evidence { attitude: false, ..e },
        Evidence::without_monitor(true, true),
    ] {
        assert!(!other.fits(), "{other:?}");
    }
}

/// The files of the workspace that may list the states: documents and
/// sources, not data or build output.
fn text_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let p = entry.path();
        let name = entry.file_name();
        let name = name.to_string_lossy();
        if p.is_dir() {
            if !(name.starts_with('.') || name == "target" || name == "data" || name == "node_modules") {
                text_files(&p, out);
            }
        } else if name.ends_with(".md") || name.ends_with(".rs") {
            out.push(p);
        }
    }
}

/// The lists of states in a text: runs of at least three states' names in
/// backticks, one after the other, separated only by a comma, `·`, `;`,
/// `or`/`and` and an explanation in parentheses. Comment markers and line
/// breaks are taken as spaces.
fn state_lists(text: &str) -> Vec<Vec<IntegrityState>> {
    let flat: String = text
        .lines()
        .map(|l| {
            let t = l.trim_start();
            t.strip_prefix("//!").or_else(|| t.strip_prefix("///")).unwrap_or(t)
        })
        .collect::<Vec<_>>()
        .join(" ");
    // Every backticked state name, with where it starts and ends.
    let mut names: Vec<(usize, usize, IntegrityState)> = Vec::new();
    let mut rest = flat.as_str();
    let mut at = 0;
    while let Some(open) = rest.find('`') {
        let after = &rest[open + 1..];
        let Some(close) = after.find('`') else { break };
        if let Some(s) = IntegrityState::from_name(&after[..close]) {
            names.push((at + open, at + open + close + 2, s));
        }
        at += open + close + 2;
        rest = &flat[at..];
    }
    let separator = |between: &str| {
        let mut b = between.trim();
        if b.starts_with('(') {
            // A parenthetical explanation, nested once at most.
            let mut depth = 0i32;
            let mut end = None;
            for (i, c) in b.char_indices() {
                depth += match c {
                    '(' => 1,
                    ')' => -1,
                    _ => 0,
                };
                if depth == 0 {
                    end = Some(i + 1);
                    break;
                }
            }
            match end {
                Some(e) => b = b[e..].trim(),
                None => return false,
            }
        }
        let b = b.trim_start_matches([',', ';', '·']).trim();
        let b = b.strip_prefix("or").or_else(|| b.strip_prefix("and")).unwrap_or(b).trim();
        b.is_empty()
    };
    let mut lists = Vec::new();
    let mut run: Vec<IntegrityState> = Vec::new();
    let mut last_end = 0;
    for (start, end, s) in names {
        if run.is_empty() || !separator(&flat[last_end..start]) {
            if run.len() >= 3 {
                lists.push(core::mem::take(&mut run));
            }
            run.clear();
        }
        run.push(s);
        last_end = end;
    }
    if run.len() >= 3 {
        lists.push(run);
    }
    lists
}

#[test]
fn the_list_finder_finds_lists_and_not_prose() {
    let lists = state_lists(
        "one `ok` · `disturbed` (a magnet) · `cal_invalid`; prose: `ok` is not `disturbed`, and\n\
         /// `cal_invalid` means; a list `ok`, `disturbed`,\n/// `cal_invalid`, `no_attitude` or `unjudged`.",
    );
    assert_eq!(lists.len(), 2, "{lists:?}");
    assert_eq!(lists[0].len(), 3);
    assert_eq!(lists[1].len(), 5);
}

/// Every list of the states in the workspace's documents and sources (the
/// INTERFACES tables, the READMEs, the doc comments) names every state.
#[test]
fn every_prose_list_of_the_states_names_every_state() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut files = Vec::new();
    text_files(&root, &mut files);
    assert!(files.iter().any(|f| f.ends_with("docs/INTERFACES.md")), "{}", root.display());
    let mut lists = 0;
    // This file's own fixtures aside.
    for f in files.iter().filter(|f| !f.ends_with(file!())) {
        let Ok(text) = std::fs::read_to_string(f) else { continue };
        for list in state_lists(&text) {
            lists += 1;
            let missing: Vec<&str> = IntegrityState::ALL
                .iter()
                .filter(|s| !list.contains(s))
                .map(|s| s.name())
                .collect();
            assert!(missing.is_empty(), "{}: a list of the states without {missing:?}", f.display());
        }
    }
    // INTERFACES (apply's column, the board log's, `$PMAGI`, the JSON) and more.
    assert!(lists >= 4, "{lists}");
}
