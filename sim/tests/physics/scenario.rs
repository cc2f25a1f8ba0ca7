//! Acceptance on simulated field tests (see `magcal_sim::scenario`).

use magcal_sim::{evaluate, SensorModel};

/// Acceptance on the paper-like scenario (thrusters add a mostly
/// horizontal running bias): the paper's back-stepping removes the step as
/// in its Table 6; ours removes it further and gives the better heading.
#[test]
fn paper_like_scenario_meets_the_acceptance_numbers() {
    for seed in [1, 2, 3] {
        let o = evaluate("paper-like", SensorModel::paper_like(), seed).unwrap();
        assert!(o.step_axis_fit_nt.abs() >= 300.0, "the sphere fit must leave a paper-like step");
        assert!(o.step_paper_nt.abs() <= 20.0);
        // Measured 2026-11-22 (seeds 1–3): step 0.0–0.4 nT, heading 0.22°,
        // field 3.6–5.1 nT, delay 2.12–2.13 s (were ≤ 5 nT, 0.5°, 50 nT, ±0.3 s).
        assert!(o.step_ours_nt.abs() <= 1.5);
        assert!(o.heading_rms_ours_deg <= 0.35);
        assert!(o.heading_rms_ours_deg < o.heading_rms_paper_deg);
        assert!(o.field_error_ours_nt <= 20.0);
        assert!((o.gps_delay_ours_s - 2.0).abs() < 0.2);
    }
}

/// A hull that couples the vertical channel to the horizontal ones: the
/// step is not one a change of `sz` removes; ours still does.
#[test]
fn hull_coupled_scenario_defeats_the_papers_sz_search_but_not_ours() {
    for seed in [4, 5] {
        let o = evaluate("hull-coupled", SensorModel::hull_coupled(), seed).unwrap();
        assert!(o.step_axis_fit_nt.abs() >= 300.0);
        assert!(o.step_paper_nt.abs() > 100.0, "the paper's correction cannot remove this step");
        // Measured 2026-11-22 (seeds 4–5): step 0.2–0.4 nT, heading 0.22°,
        // field 4.1–7.6 nT (were ≤ 5 nT, 0.5°, 50 nT).
        assert!(o.step_ours_nt.abs() <= 1.5);
        assert!(o.heading_rms_ours_deg <= 0.35);
        assert!(o.field_error_ours_nt <= 25.0);
    }
}

/// A vehicle that cannot tumble: a swing test of ±15° roll / ±5° pitch with a gyro gives the
/// heading of the full ±55° / ±10° swing test; without a gyro the axis fit
/// refuses it rather than guessing.
#[test]
fn a_limited_swing_with_a_gyro_calibrates_as_well_as_the_full_one() {
    use magcal_sim::scenario::{evaluate_limited, LimitedSwing};
    let sensor = SensorModel::paper_like();
    let full = evaluate_limited(sensor, 11, LimitedSwing { roll_amp_deg: 55.0, pitch_amp_deg: 10.0, gyro: true }).unwrap();
    let limited = evaluate_limited(sensor, 11, LimitedSwing { roll_amp_deg: 15.0, pitch_amp_deg: 5.0, gyro: true }).unwrap();
    let no_gyro = evaluate_limited(sensor, 11, LimitedSwing { roll_amp_deg: 15.0, pitch_amp_deg: 5.0, gyro: false }).unwrap();
    let (f, l) = (full.heading_rms_deg.unwrap(), limited.heading_rms_deg.unwrap());
    assert!((l - f).abs() < 0.1, "±15/±5 {l}° vs ±55/±10 {f}°");
    assert!(l <= 0.35, "{l}");
    assert!(no_gyro.refused.as_deref().is_some_and(|r| r.contains("of field directions were visited")), "{no_gyro:?}");
}

/// The chain on the effects runs, with its models of the
/// thrusters, temperature, local field, misalignment and water current.
/// Before them (2026-11-23, seed 1): current 2.95°, temperature 1.02°
/// (field error 483 nT), all five 3.76° (530 nT); with no effect 0.22°.
/// The GPS delay (truth 2 s, independent of the chain) sat at the 5 s
/// search limit whenever the current was on, until the delay search
/// alternated with the current estimate.
#[test]
fn real_vehicle_effects_with_the_new_models() {
    use magcal_sim::scenario::evaluate_effects;
    use magcal_sim::{Effect, Effects};
    let sensor = SensorModel::paper_like();
    // Measured (seed 1): none 0.22°, current 0.22° (delay 2.15 s),
    // temperature 0.22° (field error 12 nT), all five 0.28° (delay 1.87 s).
    let none = evaluate_effects("none", sensor, 1, &Effects::none()).unwrap();
    assert!(none.heading_rms_ours_deg <= 0.35, "{}", none.heading_rms_ours_deg);
    let current = evaluate_effects("current", sensor, 1, &Effects::of(&[Effect::Current])).unwrap();
    assert!(current.heading_rms_ours_deg < 0.35, "{}", current.heading_rms_ours_deg);
    assert!((current.gps_delay_ours_s - 2.0).abs() < 0.5, "{current:?}");
    let temperature = evaluate_effects("temperature", sensor, 1, &Effects::of(&[Effect::Temperature])).unwrap();
    assert!(temperature.heading_rms_ours_deg < 0.35 && temperature.field_error_ours_nt < 50.0, "{temperature:?}");
    let all = evaluate_effects("all", sensor, 1, &Effects::all()).unwrap();
    assert!(all.heading_rms_ours_deg < 0.45, "{all:?}");
    assert!((all.gps_delay_ours_s - 2.0).abs() < 0.5, "{all:?}");
}
