//! The layering of host-tools' modules, read from the sources: no module
//! names a module of a layer above its own.
//!
//! The layers, lowest first (a module may use its own layer and those
//! below; the crate root, `lib.rs`, is above them all):
//!
//! 1. `files`, `geomag`, `procedure`: leaves (atomic output, the world
//!    model, the field procedure's limits);
//! 2. `doc`: the documents and their typed parts, and every limit a
//!    document is checked against;
//! 3. `data`: tables, recordings, logs and their importers;
//! 4. `compute`: the fits and the calibration chain;
//! 5. `board`, `export`, `report`: the board client, the autopilots'
//!    parameters, the figures and the page;
//! 6. `session`: the calibration session, which drives the board and
//!    writes the report.
//!
//! A reference is any path through the crate's root — `crate::m`,
//! `$crate::m`, `host_tools::m` (a doc example), each name of a
//! `crate::{…}` group — or a `super::` chain that climbs out of the
//! top-level module, anywhere in a file: code, tests and rustdoc links
//! alike. Every top-level module declared in `lib.rs` must have a layer.

use std::path::{Path, PathBuf};

/// The layers, lowest first.
const LAYERS: &[&[&str]] = &[&["files", "geomag", "procedure"], &["doc"], &["data"], &["compute"], &["board", "export", "report"], &["session"]];

fn layer_of(module: &str) -> Option<usize> {
    LAYERS.iter().position(|l| l.contains(&module))
}

fn src() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let p = entry.unwrap().path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|e| e == "rs") {
            out.push(p);
        }
    }
}

fn is_ident(c: char) -> bool {
    c.is_alphanumeric() || c == '_'
}

fn ident_at(s: &str) -> &str {
    let end = s.find(|c: char| !is_ident(c)).unwrap_or(s.len());
    &s[..end]
}

/// The first name of each item of the brace group `s` starts with.
fn group_names(s: &str) -> Vec<&str> {
    let mut names = Vec::new();
    let mut depth = 0usize;
    let mut item_start = 1;
    for (i, c) in s.char_indices() {
        match c {
            '{' => depth += 1,
            '}' | ',' if depth == 1 => {
                names.push(ident_at(s[item_start..i].trim_start()));
                item_start = i + 1;
                if c == '}' {
                    break;
                }
            }
            '}' => depth -= 1,
            _ => {}
        }
    }
    names.into_iter().filter(|n| !n.is_empty()).collect()
}

/// The top-level modules a file's text names through the crate's root or
/// a `super::` chain out of its own top-level module, with the line.
/// `depth`: how many modules deep the file is (`data/caldoc.rs` 2,
/// `data/mod.rs` 1).
fn references(text: &str, depth: usize) -> Vec<(String, usize)> {
    let line = |at: usize| text[..at].matches('\n').count() + 1;
    let mut found = Vec::new();
    for root in ["crate::", "host_tools::"] {
        for (at, _) in text.match_indices(root) {
            if text[..at].chars().next_back().is_some_and(is_ident) {
                continue;
            }
            let rest = &text[at + root.len()..];
            let names = if rest.starts_with('{') { group_names(rest) } else { vec![ident_at(rest)] };
            found.extend(names.into_iter().map(|n| (n.to_string(), line(at))));
        }
    }
    for (at, _) in text.match_indices("super::") {
        if text[..at].ends_with("super::") || text[..at].chars().next_back().is_some_and(is_ident) {
            continue;
        }
        let rest = &text[at..];
        let mut climbs = 0;
        let mut tail = rest;
        while let Some(t) = tail.strip_prefix("super::") {
            climbs += 1;
            tail = t;
        }
        // Inline modules (`mod tests`) add depth this count does not see:
        // a chain that seems to reach the root from one may not; only a
        // name of a top-level module is taken as a reference.
        if climbs >= depth {
            found.push((ident_at(tail).to_string(), line(at)));
        }
    }
    found
}

/// Every reference from a module to a module of a higher layer, or to a
/// module without a layer, as `file:line: from → to`.
fn violations(src: &Path) -> Vec<String> {
    let lib = std::fs::read_to_string(src.join("lib.rs")).unwrap();
    let declared: Vec<&str> = lib
        .lines()
        .filter_map(|l| l.trim().strip_prefix("pub mod ").or_else(|| l.trim().strip_prefix("mod ")))
        .filter_map(|l| l.strip_suffix(';'))
        .collect();
    let mut bad: Vec<String> = declared.iter().filter(|m| layer_of(m).is_none()).map(|m| format!("lib.rs: module `{m}` has no layer")).collect();
    let mut files = Vec::new();
    rust_files(src, &mut files);
    files.sort();
    for path in files {
        let rel = path.strip_prefix(src).unwrap();
        let parts: Vec<String> = rel.iter().map(|p| p.to_string_lossy().into_owned()).collect();
        if parts == ["lib.rs"] {
            continue;
        }
        let from = parts[0].trim_end_matches(".rs").to_string();
        let depth = parts.len() - usize::from(parts.last().is_some_and(|f| f == "mod.rs"));
        let Some(from_layer) = layer_of(&from) else {
            bad.push(format!("{}: module `{from}` has no layer", rel.display()));
            continue;
        };
        let text = std::fs::read_to_string(&path).unwrap();
        for (to, line) in references(&text, depth) {
            if to == from || !declared.contains(&to.as_str()) {
                continue;
            }
            match layer_of(&to) {
                Some(l) if l <= from_layer => {}
                _ => bad.push(format!("{}:{line}: {from} → {to}", rel.display())),
            }
        }
    }
    bad
}

#[test]
fn no_module_names_a_module_of_a_higher_layer() {
    let bad = violations(&src());
    assert!(bad.is_empty(), "{} references against the layering (see this file's header):\n{}", bad.len(), bad.join("\n"));
}

/// The reader finds each form of reference (and none in a lower module's
/// own paths), so the test above can fail.
#[test]
fn the_reader_finds_every_form_of_reference() {
    let text = "use crate::doc::CalDoc;\nuse crate::{data::Recording, compute::{fit, auto}};\n/// [`crate::session`] and `host_tools::report::x`\n$crate::board::y\nuse super::super::export;\nuse super::sibling;\nnot_crate::geomag\n";
    let mut names: Vec<String> = references(text, 2).into_iter().map(|(n, _)| n).collect();
    names.sort();
    assert_eq!(names, ["board", "compute", "data", "doc", "export", "report", "session"]);
    assert_eq!(references("use super::super::export;", 3), vec![], "a chain within the top-level module");
}
