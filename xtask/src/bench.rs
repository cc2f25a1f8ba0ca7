//! `cargo xtask bench [--section NAME]...`: accuracy benchmarks. Writes
//! `target/bench/results.json` and `target/bench/results.md`, and
//! `docs/results.json` with `docs/RESULTS.md` rendered from it
//! (`crate::results_doc`).
//!
//! One module per section; [`run`] runs them in turn and joins their
//! Markdown in the order of `results.md`, then checks the sections'
//! targets ([`targets`]); [`run_ci`] (`cargo xtask bench --ci`) runs the
//! sections that state targets at CI sizes and only checks them.

use std::path::{Path, PathBuf};

use anyhow::{bail, Result};
use serde_json::{json, Value};

mod compass;
mod effects;
mod fit_speed;
mod host_throughput;
mod import_speed;
mod integrity;
mod integrity_table;
mod limited_tilt;
mod mcu;
mod merge;
mod paper000;
mod paper001;
mod real_data;
mod real_recordings;
mod targets;
mod varied;

use effects::{effects, EFFECTS_SEEDS};
use host_throughput::host_throughput;
use limited_tilt::limited_tilt;
use mcu::{cpu_budget, mcu_costs};
use merge::{merge_clocks, MERGE_SHAPE_SEEDS};
use paper000::paper000;
use paper001::{f32_vs_f64, figures, paper001, SEEDS};
use real_recordings::real_recordings;

/// Runs the benchmarks (every section, or those named in `only`: the names
/// of [`crate::results_doc::SECTIONS`]) and writes the results:
/// `target/bench/results.{json,md}`, `docs/results.json` and `docs/RESULTS.md`.
/// With `only`, the other sections are kept from the previous
/// `target/bench/results.json` (or, where there is none, the committed
/// `docs/results.json`), each with its own date and commit.
pub fn run(out_dir: &Path, only: &[String]) -> Result<()> {
    let known: Vec<&str> = crate::results_doc::SECTIONS.iter().map(|s| s.0).collect();
    if let Some(bad) = only.iter().find(|s| !known.contains(&s.as_str())) {
        bail!("no bench section `{bad}` (the sections: {})", known.join(", "));
    }
    let want = |name: &str| only.is_empty() || only.iter().any(|s| s == name);
    std::fs::create_dir_all(out_dir)?;
    let root = out_dir.join("../..");
    let root = root.canonicalize().unwrap_or(root);
    // The other sections come from this machine's last run or, on a fresh
    // clone, from the committed `docs/results.json`: a one-section run
    // never empties the rest of `docs/RESULTS.md`.
    let read = |p: PathBuf| std::fs::read_to_string(p).ok().and_then(|t| serde_json::from_str::<Value>(&t).ok()).filter(Value::is_object);
    let previous = read(out_dir.join("results.json")).or_else(|| read(root.join("docs/results.json")));
    let mut results = match previous {
        Some(p) if !only.is_empty() && p.is_object() => p,
        _ => json!({}),
    };
    results["command"] = json!("cargo xtask bench");
    let stamp = crate::results_doc::stamp(&root);
    let piece = |results: &mut Value, name: &str, md: String| {
        results["markdown"][name] = json!(md);
        results["generated"][name] = stamp.clone();
    };
    if want("mcu") {
        eprintln!("== MCU cost (instructions under QEMU -icount)");
        let mut mcu = mcu_costs(&root)?;
        let usage = crate::size::measure(&root.join("target/thumbv7em-none-eabihf/release/firmware")).ok();
        if let Some(u) = usage {
            mcu["flash_bytes"] = json!(u.flash_bytes);
            mcu["ram_bytes"] = json!(u.ram_bytes);
        }
        let budget = cpu_budget(&mcu);
        if let (Some(obj), Some(b)) = (mcu.as_object_mut(), budget.as_object()) {
            for (k, v) in b {
                obj.insert(k.clone(), v.clone());
            }
        }
        eprintln!("{}", serde_json::to_string_pretty(&mcu)?);
        piece(&mut results, "mcu", mcu::markdown(&mcu)?);
        if let Some(obj) = mcu.as_object() {
            for (k, v) in obj {
                results[k] = v.clone();
            }
        }
    }
    if want("paper001") {
        eprintln!("== paper 001: J vs N and σ ({SEEDS} seeds each)");
        let (p1, p1_md) = paper001();
        eprintln!("{p1_md}");
        results["figures"] = json!(figures(out_dir, &p1)?);
        results["paper001_j"] = p1;
        piece(&mut results, "paper001", paper001::markdown(&p1_md));
    }
    if want("f32") {
        let f32_check = f32_vs_f64();
        eprintln!("== f32 recursive full fit vs f64 batch (2400-sample tumble, 50 000 nT, 0.4 nT noise): {f32_check}");
        piece(&mut results, "f32", paper001::f32_markdown(&f32_check));
        results["f32_rls_vs_f64_batch"] = f32_check;
    }
    if want("paper000") {
        eprintln!("== paper 000: simulated field tests (5 seeds × 2 vehicles)");
        let (p0, p0_md) = paper000();
        eprintln!("{p0_md}");
        results["paper000_scenarios"] = p0;
        piece(&mut results, "paper000", paper000::markdown(&p0_md));
    }
    if want("host-throughput") {
        eprintln!("== host throughput (10⁶ samples)");
        let host = host_throughput(&root);
        eprintln!("{}", serde_json::to_string_pretty(&host)?);
        piece(&mut results, "host-throughput", host_throughput::markdown(&host)?);
        results["host_throughput"] = host;
    }
    if want("real-recordings") {
        let real = real_recordings(&root);
        eprintln!("== real recordings: {real}");
        piece(&mut results, "real-recordings", real_recordings::markdown(&real));
        results["real_recordings"] = real;
    }
    if want("limited-tilt") {
        eprintln!("== limited tilt: simulated swing tests with and without a gyro, broad-05 against the peers");
        let (limited, limited_md) = limited_tilt(&root);
        eprintln!("{limited_md}");
        results["limited_tilt"] = limited;
        piece(&mut results, "limited-tilt", limited_tilt::markdown(&limited_md));
    }
    if want("report-render") {
        // The report of a full session (`cargo xtask demo`) in headless Chromium:
        // browser start to screenshot, s (target ≤ 2 s).
        let report_page = root.join("target/demo/session/report/index.html");
        let (render_s, md) = match crate::browser::check_report(&report_page) {
            Ok(r) => {
                // The browser's own start, for scale: an empty page the same way.
                let empty = out_dir.join("empty.html");
                let start_s = std::fs::write(&empty, "<!doctype html><title>empty</title><link rel=\"icon\" href=\"data:,\">")
                    .map_err(anyhow::Error::from)
                    .and_then(|()| crate::browser::render(&empty, &out_dir.join("empty.png"), crate::browser::WINDOW))
                    .map_or(f64::NAN, |e| e.render_s);
                let line = format!("The demo's report page (`target/demo/session/report/index.html`) in headless Chromium, browser start to screenshot: {:.2} s (target ≤ 2 s; an empty page the same way: {start_s:.2} s).", r.render_s);
                eprintln!("== report render: {line}");
                (json!(r.render_s), line)
            }
            Err(e) => {
                eprintln!("== report render: not measured ({e:#}; run `cargo xtask demo` first)");
                (json!(null), format!("Not measured: {e:#} (run `cargo xtask demo` first)."))
            }
        };
        results["report_render_s"] = render_s;
        piece(&mut results, "report-render", md);
    }
    if want("real-data") {
        let (real_data, real_data_md) = real_data::real_data(&root);
        eprintln!("== real recordings, every model{real_data_md}");
        results["real_data"] = real_data;
        piece(&mut results, "real-data", real_data_md);
    }
    if want("merge") {
        eprintln!("== merge: clocks ±60 s and ±100 ppm apart at 50, 5 and 1 Hz, with and without a heading, {} seeds", MERGE_SHAPE_SEEDS.len());
        let (merge_numbers, merge_md) = merge_clocks();
        eprintln!("{merge_md}");
        results["merge"] = merge_numbers;
        piece(&mut results, "merge", merge::markdown(&merge_md));
    }
    if want("effects") {
        eprintln!("== effects: five real-vehicle effects, {} seeds", EFFECTS_SEEDS.len());
        let (effects_numbers, effects_md) = effects();
        eprintln!("{effects_md}");
        results["effects"] = effects_numbers;
        piece(&mut results, "effects", effects::markdown(&effects_md));
    }
    if want("integrity") {
        let integrity = integrity::section(&root);
        piece(&mut results, "integrity", integrity_table::markdown(&integrity));
        results["integrity"] = integrity;
    }
    if want("compass") {
        eprintln!("== a heading-only compass's swing on the yacht Cirrus's circles");
        let (compass_numbers, compass_md) = compass::section(&root);
        eprintln!("{compass_md}");
        results["compass_swing"] = compass_numbers;
        piece(&mut results, "compass", compass::markdown(&compass_md));
    }
    if want("varied") {
        eprintln!("== the five effects on varied sites with drawn magnitudes, {} seeds", varied::VARIED_SEEDS.len());
        let (varied_numbers, varied_md) = varied::varied_sites_section();
        eprintln!("{varied_md}");
        results["effects_varied_sites"] = varied_numbers;
        piece(&mut results, "varied", varied::markdown(&varied_md));
    }
    if want("import-speed") {
        eprintln!("== import speed per format beside the independent readers");
        let (import_numbers, import_md) = import_speed::section(&root);
        eprintln!("{import_md}");
        results["import_speed"] = import_numbers;
        piece(&mut results, "import-speed", import_speed::markdown(&import_md));
    }
    if want("fit-speed") {
        eprintln!("== fit speed: `fit` auto and attitude beside scipy's least_squares, 10⁴ to 10⁶ rows");
        let (fit_speed_numbers, fit_speed_md) = fit_speed::section(&root);
        eprintln!("{fit_speed_md}");
        results["fit_speed"] = fit_speed_numbers;
        piece(&mut results, "fit-speed", fit_speed::markdown(&fit_speed_md));
    }
    crate::results_doc::write_atomic(&out_dir.join("results.json"), &serde_json::to_string_pretty(&results)?)?;
    // `results.md`: the pieces it always had, in its order.
    let md = ["mcu", "paper000", "paper001", "limited-tilt", "merge", "effects", "f32", "host-throughput", "varied", "import-speed", "fit-speed", "compass"]
        .iter()
        .filter_map(|name| results["markdown"][*name].as_str())
        .fold("# Benchmarks (`cargo xtask bench`)\n\n".to_string(), |md, piece| md + piece);
    crate::results_doc::write_atomic(&out_dir.join("results.md"), &md)?;
    eprintln!("wrote {}", out_dir.join("results.json").display());
    crate::results_doc::write_docs(&root, &results)?;
    // The targets of the sections run now.
    let mut all = Vec::new();
    for (name, targets) in [
        ("mcu", mcu::targets as fn(&serde_json::Value) -> Vec<targets::Target>),
        ("effects", effects::targets),
        ("varied", varied::targets),
        ("integrity", integrity::targets),
        ("real-data", real_data::targets),
        ("fit-speed", fit_speed::targets),
    ] {
        let key = match name {
            "varied" => "effects_varied_sites",
            "real-data" => "real_data",
            "fit-speed" => "fit_speed",
            other => other,
        };
        // The MCU figures sit at the top level of the results.
        let v = if name == "mcu" { &results } else { &results[key] };
        if want(name) {
            all.extend(targets(v));
        }
    }
    report(&all, "the full bench")
}

/// Prints one line per target and the count (libtest's words, so that
/// `cargo xtask test` counts them); fails naming every miss.
fn report(all: &[targets::Target], sizes: &str) -> Result<()> {
    let (lines, misses) = targets::check(all);
    for l in &lines {
        println!("{l}");
    }
    let verdict = if misses.is_empty() { "ok" } else { "FAILED" };
    println!("test result: {verdict}. {} passed; {} failed; 0 ignored; 0 measured; 0 filtered out (bench targets, {sizes})", all.len() - misses.len(), misses.len());
    if !misses.is_empty() {
        let list: Vec<String> = misses.iter().map(ToString::to_string).collect();
        bail!("{} bench target(s) missed:\n  {}", misses.len(), list.join("\n  "));
    }
    Ok(())
}

/// `cargo xtask bench --ci`: the sections that state targets (MCU,
/// effects, varied sites, integrity, real data) at [`targets::Sizes::CI`],
/// their targets checked; nothing written. The MCU section needs the
/// board's release build of `mcu-bench` (it builds it) and QEMU.
pub fn run_ci(root: &Path) -> Result<()> {
    let sizes = targets::Sizes::CI;
    let described = format!(
        "CI sizes: effects seeds {:?}, the chain with every model only (the full bench: also each model off, the paper's method, each effect alone); varied sites seeds {:?}, the chain with the gradient only (the full bench: also the chain without it and the leave-one-site-out prior); integrity the shipped tuning only (the full bench: the 1 620-point leave-one-out grid and the gate curve); real data fit without --model and the wrong calibrations (the full bench: every model and the attitude fit's leave-one-out defaults)",
        sizes.effects_seeds, sizes.varied_seeds
    );
    println!("bench targets at {described}");
    let section = |name: &str, f: &mut dyn FnMut() -> Vec<targets::Target>| {
        let started = std::time::Instant::now();
        let t = f();
        println!("{name}: {:.1} s", started.elapsed().as_secs_f64());
        t
    };
    let mcu_targets = section("mcu", &mut || {
        let mut m = mcu_costs(root).unwrap_or_else(|e| json!({"error": format!("{e:#}")}));
        if let Ok(u) = crate::size::measure(&root.join("target/thumbv7em-none-eabihf/release/firmware")) {
            m["flash_bytes"] = json!(u.flash_bytes);
        }
        let budget = cpu_budget(&m);
        if let (Some(obj), Some(b)) = (m.as_object_mut(), budget.as_object()) {
            for (k, v) in b {
                obj.insert(k.clone(), v.clone());
            }
        }
        mcu::targets(&m)
    });
    let effects_targets = section("effects", &mut || effects::targets(&effects::effects_with(sizes.effects_seeds, sizes.effects_other_chains).0));
    let varied_targets = section("varied", &mut || varied::targets(&varied::varied_sites_with(sizes.varied_seeds, sizes.varied_choice).0));
    let integrity_targets = section("integrity", &mut || integrity::targets(&integrity::shipped_only(root)));
    let real_targets = section("real data", &mut || real_data::targets(&real_data::real_data_with(root, false).0));
    report(&[mcu_targets, effects_targets, varied_targets, integrity_targets, real_targets].concat(), "CI sizes")
}

#[cfg(test)]
mod tests {
    /// Only the merge section (the clock tables, then the chain on merged
    /// logs): `cargo test --release -p xtask bench::tests::merge_section -- --ignored --nocapture`.
    #[test]
    #[ignore = "a benchmark: prints its numbers"]
    fn merge_section() {
        let (v, md) = super::merge_clocks();
        eprintln!("{md}");
        for r in v["rates"].as_array().into_iter().flatten() {
            assert_eq!(r["refused"].as_u64(), Some(0), "{r}");
            assert!(r["worst_offset_error_ms"].as_f64().is_some_and(|w| w < r["target_ms"].as_f64().unwrap_or(0.0)), "{r}");
            assert!(r["error_over_sigma"].as_f64().is_some_and(|q| (0.5..=2.0).contains(&q)), "{r}");
        }
    }

    /// Only the merge section's clock tables, one row per log shape (a
    /// couple of minutes): `cargo test --release -p xtask
    /// bench::tests::merge_shapes -- --ignored --nocapture`.
    #[test]
    #[ignore = "a benchmark: prints its numbers"]
    fn merge_shapes() {
        let (rates, md) = super::merge::merge_shapes();
        eprintln!("{md}");
        for r in &rates {
            assert_eq!(r["refused"].as_u64(), Some(0), "{r}");
            assert!(r["worst_offset_error_ms"].as_f64().is_some_and(|w| w < r["target_ms"].as_f64().unwrap_or(0.0)), "{r}");
            assert!(r["error_over_sigma"].as_f64().is_some_and(|q| (0.5..=2.0).contains(&q)), "{r}");
        }
    }

    /// Only the MCU section (instruction counts under QEMU, the CPU budget):
    /// `cargo test -p xtask bench::tests::mcu_section -- --ignored --nocapture`.
    #[test]
    #[ignore = "a benchmark: prints its numbers"]
    fn mcu_section() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let mcu = super::mcu_costs(&root).expect("mcu-bench under QEMU");
        let budget = super::cpu_budget(&mcu);
        eprintln!("{}\n{}", serde_json::to_string_pretty(&mcu).unwrap_or_default(), serde_json::to_string_pretty(&budget).unwrap_or_default());
        assert!(budget["cpu_busy_pct_at_pair_rate"].as_f64().is_some_and(|p| p > 0.0 && p < 100.0), "{budget}");
        let mut all = mcu.clone();
        if let (Some(obj), Some(b)) = (all.as_object_mut(), budget.as_object()) {
            obj.extend(b.clone());
        }
        if let Ok(u) = crate::size::measure(&root.join("target/thumbv7em-none-eabihf/release/firmware")) {
            all["flash_bytes"] = serde_json::json!(u.flash_bytes);
        }
        let misses = super::targets::check(&super::mcu::targets(&all)).1;
        assert!(misses.is_empty(), "{misses:?}");
    }

    /// Only the varied-sites section:
    /// `cargo test --release -p xtask bench::tests::varied_sites_section -- --ignored --nocapture`.
    /// Prints the tables; asserts only that every site and seed ran.
    #[test]
    #[ignore = "a benchmark: prints its numbers"]
    fn varied_sites_section() {
        let (v, md) = super::varied::varied_sites_section();
        eprintln!("{md}");
        for s in v["summary"].as_array().into_iter().flatten() {
            assert_eq!(s["seeds"].as_u64(), Some(super::varied::VARIED_SEEDS.len() as u64), "{s}");
        }
        let misses = super::targets::check(&super::varied::targets(&v)).1;
        assert!(misses.is_empty(), "{misses:?}");
    }

    /// Only the import-speed section:
    /// `cargo test --release -p xtask bench::tests::import_speed_section -- --ignored --nocapture`.
    /// Every fixture is in the tree and imports; ours is not slower than
    /// the independent reader where that was measured.
    #[test]
    #[ignore = "a benchmark: prints its numbers"]
    fn import_speed_section() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let (v, md) = super::import_speed::section(&root);
        eprintln!("{md}");
        for row in v.as_array().into_iter().flatten() {
            assert!(row["rows"].as_u64().is_some_and(|n| n > 0), "{row}");
            if let Some(r) = row["ratio"].as_f64() {
                assert!(r >= 1.0, "{row}");
            }
        }
    }

    /// Only the fit-speed section, from a release build:
    /// `cargo test --release -p xtask bench::tests::fit_speed_section -- --ignored --nocapture`.
    /// Every row was fitted by both, and the attitude fit's coefficients are
    /// scipy's on the same model (measured: within 4.7e-6 of the gain and
    /// the field at 10⁴ rows, 7.5e-7 at 66 500, 5e-8 at 10⁶; the Huber
    /// scales differ slightly).
    #[test]
    #[ignore = "a benchmark: prints its numbers"]
    fn fit_speed_section() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let (v, md) = super::fit_speed::section(&root);
        eprintln!("{md}");
        for row in v["rows"].as_array().into_iter().flatten() {
            assert!(row["auto_s"].as_f64().is_some() && row["attitude_s"].as_f64().is_some(), "{row}");
            if let Some(d) = row["attitude_vs_scipy_coefficients"].as_f64() {
                assert!(d < 1e-4, "{row}");
            }
        }
        let misses = super::targets::check(&super::fit_speed::targets(&v)).1;
        assert!(misses.is_empty(), "{misses:?}");
    }

    /// Only the effects section: `cargo test -p xtask bench::tests::effects_section -- --ignored --nocapture`.
    /// Prints the table; asserts that every seed of the full chain ran and
    /// the section's targets ([`super::effects::targets`]).
    #[test]
    #[ignore = "a benchmark: prints its numbers"]
    fn effects_section() {
        let (v, md) = super::effects();
        eprintln!("{md}");
        assert_eq!(v["targets"]["seeds"].as_u64(), Some(super::EFFECTS_SEEDS.len() as u64), "{}", v["targets"]);
        let misses = super::targets::check(&super::effects::targets(&v)).1;
        assert!(misses.is_empty(), "{misses:?}");
    }

    /// The MCU section's targets read the figures `mcu-bench` and the CPU
    /// budget name: a per-sample path one instruction over 300 and an
    /// integrity one over its budget fail, naming the section and the number.
    #[test]
    fn the_mcu_targets_read_the_bench_s_figures_and_fail_past_them() {
        let mut mcu = serde_json::json!({
            "apply_env_heading_instructions": 259, "integrity_ok_turn_instructions": 573, "apply_heading_turn_instructions": 228,
            "acquisition_cycle_instructions": 5563, "rls_full_update_instructions": 1192, "integrity_cal_invalid_instructions": 1491,
            "flash_bytes": 72836,
        });
        let budget = super::cpu_budget(&mcu);
        if let (Some(obj), Some(b)) = (mcu.as_object_mut(), budget.as_object()) {
            obj.extend(b.clone());
        }
        let (lines, misses) = super::targets::check(&super::mcu::targets(&mcu));
        assert!(misses.is_empty(), "{misses:?} {lines:?}");
        mcu["apply_env_heading_instructions"] = serde_json::json!(301);
        mcu["integrity_ok_turn_instructions"] = serde_json::json!(228.0 + super::mcu::INTEGRITY_INSTRUCTIONS_MAX + 1.0);
        let misses = super::targets::check(&super::mcu::targets(&mcu)).1;
        let text: Vec<String> = misses.iter().map(ToString::to_string).collect();
        assert_eq!(text.len(), 2, "{text:?}");
        assert!(text[0].starts_with("mcu: ") && text[0].contains("is 301, target ≤ 300"), "{text:?}");
        assert!(text[1].contains(&format!("is {}, target ≤ {}", super::mcu::INTEGRITY_INSTRUCTIONS_MAX + 1.0, super::mcu::INTEGRITY_INSTRUCTIONS_MAX)), "{text:?}");
    }
}
