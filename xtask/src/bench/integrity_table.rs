//! The integrity section's Markdown, made from its numbers
//! ([`super::integrity::section`]'s JSON): one row a trial with the shipped
//! tuning and the leave-one-trial-out choice, then the curve over the gates.

use std::fmt::Write as _;

use serde_json::Value;

/// A percentage with one decimal, or `—` where the trial has no such rows.
fn pct(v: &Value) -> String {
    v.as_f64().map_or("—".into(), |p| format!("{p:.1} %"))
}

/// A value with two decimals, or `—`.
fn num(v: &Value) -> String {
    v.as_f64().map_or("—".into(), |p| format!("{p:.2}"))
}

/// The section's Markdown from its JSON.
pub fn markdown(v: &Value) -> String {
    let mut md = String::new();
    if let Some(e) = v["error"].as_str() {
        let _ = writeln!(md, "Not measured: {e}.");
        return md;
    }
    let _ = writeln!(
        md,
        "`magcal apply`'s per-sample integrity (the board's code) on every BROAD trial with an optical heading, each with its \
         undisturbed calibration and the lab's inclination as the reference. Rows off by more than 5° (after one constant offset, \
         taken robustly) are *bad*, within 2° *good*. Shipped tuning: `{}`; chosen leave-one-trial-out (the grid point that best \
         meets the targets on the other trials, reported on the one left out). `cargo test --release -p xtask \
         bench::integrity::tests::integrity_section -- --ignored --nocapture`.\n\n\
         | trial | kind | rows | bad rows flagged | rows > 10° flagged | good rows `ok` | all rows `ok` | `ok` rows RMS (°) | \
         observed / predicted | left out: bad flagged | left out: good `ok` | targets met |\n|---|---|---|---|---|---|---|---|---|---|---|---|",
        v["shipped"]
    );
    let trials = v["trials"].as_object();
    for (name, t) in trials.into_iter().flatten() {
        let (s, l) = (&t["shipped"], &t["leave_one_out"]);
        let _ = writeln!(
            md,
            "| {name} | {} | {} | {} of {} | {} of {} | {} | {} | {} | {} | {} | {} | {} |",
            s["kind"].as_str().unwrap_or("?"),
            s["rows"],
            pct(&s["bad_not_ok_pct"]),
            s["bad_rows"],
            pct(&s["gross_not_ok_pct"]),
            s["gross_rows"],
            pct(&s["good_ok_pct"]),
            pct(&s["ok_pct"]),
            num(&s["ok_rms_deg"]),
            num(&s["sigma_ratio"]),
            pct(&l["bad_not_ok_pct"]),
            pct(&l["good_ok_pct"]),
            if s["meets"].as_bool() == Some(true) { "yes" } else { "no" },
        );
    }
    let _ = writeln!(md, "\nThe curve over the gates (every gate × k; bad flagged % / good `ok` % / `ok` RMS °; **bold**: the shipped point):\n");
    let ks: Vec<f64> = trials
        .and_then(|t| t.values().next())
        .and_then(|t| t["curve"].as_array())
        .map(|c| c.iter().filter_map(|p| p["gates_times"].as_f64()).collect())
        .unwrap_or_default();
    let _ = writeln!(md, "| trial | {} |\n|---|{}", ks.iter().map(|k| format!("× {k}")).collect::<Vec<_>>().join(" | "), "---|".repeat(ks.len()));
    for (name, t) in trials.into_iter().flatten() {
        let cells: Vec<String> = t["curve"]
            .as_array()
            .into_iter()
            .flatten()
            .map(|p| {
                let f = |v: &Value, d: usize| v.as_f64().map_or("—".into(), |x| format!("{x:.d$}"));
                let c = format!("{} / {} / {}", f(&p["flagged_pct"], 0), f(&p["good_ok_pct"], 0), f(&p["ok_rms_deg"], 1));
                if p["shipped"].as_bool() == Some(true) { format!("**{c}**") } else { c }
            })
            .collect();
        let _ = writeln!(md, "| {name} | {} |", cells.join(" | "));
    }
    let g = &v["seaglider-sg236"];
    if g.is_object() {
        let _ = writeln!(
            md,
            "\nSeaglider SG236 (no gyro, no heading reference; the glider's own calibration, IGRF-14 as its reference), below 3 m: \
             {} `ok` of {} rows; states `{}`.",
            pct(&g["below_3m"]["ok_pct"]),
            g["below_3m"]["rows"],
            g["below_3m"]["states"]
        );
    }
    md
}
