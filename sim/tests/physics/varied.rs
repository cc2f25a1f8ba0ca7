//! The five effects on sites unlike paper 000's and with magnitudes drawn
//! by seed: the chain reaches its heading target
//! against the simulator's true heading, its prediction stays honest, and
//! the joint back-stepping's field gradient along the track is the one the
//! simulator's true field has. Fixed seeds; about 20 s in release
//! (`cargo test --release -p magcal-sim --test physics varied::`).

use host_tools::compute::{self, Chain};
use host_tools::geomag;
use magcal_sim::scenario::{evaluate_options, varied_effects_data, EffectsData, Variant};
use magcal_sim::varied::varied_sites;
use magcal_sim::SensorModel;

/// The target for the validation true-heading RMS, °.
const TARGET_DEG: f64 = 0.25;

fn data(site: &str, seed: u64) -> EffectsData {
    let s = varied_sites().into_iter().find(|s| s.name == site).expect("a varied site");
    varied_effects_data(&SensorModel::paper_like(), &s.site, seed).expect("simulation")
}

/// The true anomaly's gradient along the track (`∂H/∂s, ∂Z/∂s`, nT/m)
/// over the calibration run: the least-squares slope of the true field's
/// horizontal intensity and down component less IGRF's against the true
/// distance from the site along `direction` — from the simulator's truth
/// columns only.
fn true_gradient(sim: &magcal_sim::Simulation, direction: [f64; 2]) -> [f64; 2] {
    let col = |n: &str| sim.effect_column(n).expect(n);
    let (n, e, d, lat, lon) = (col("true_field_n_nt"), col("true_field_e_nt"), col("true_field_d_nt"), col("true_lat_deg"), col("true_lon_deg"));
    let site = sim.truth.site;
    let (mut s, mut h, mut z) = (vec![], vec![], vec![]);
    for i in (0..n.len()).step_by(20) {
        let igrf = geomag::igrf14(lat[i], lon[i], 0.0, site.decimal_year).expect("IGRF");
        let [north_m, east_m] = calib_core::water_current::local_north_east_m(lat[i], lon[i], site.lat_deg, site.lon_deg);
        s.push(north_m * direction[0] + east_m * direction[1]);
        h.push(n[i].hypot(e[i]) - igrf.horizontal_nt());
        z.push(d[i] - igrf.down_nt);
    }
    let slope = |y: &[f64]| {
        let k = s.len() as f64;
        let (ms, my) = (s.iter().sum::<f64>() / k, y.iter().sum::<f64>() / k);
        let sxy: f64 = s.iter().zip(y).map(|(a, b)| (a - ms) * (b - my)).sum();
        let sxx: f64 = s.iter().map(|a| (a - ms).powi(2)).sum();
        sxy / sxx
    };
    [slope(&h), slope(&z)]
}

#[test]
fn the_varied_sites_reach_the_heading_target_with_honest_predictions() {
    // Measured (release): low-latitude seeds 1, 2: 0.064°, 0.061° (white
    // noise 0.053°), observed/predicted 1.07, 1.02; southern seeds 1, 2:
    // 0.137°, 0.131° (white noise 0.124°, 0.127°), 1.05, 1.01.
    let mut ratios = Vec::new();
    for (site, seed) in [("low-latitude", 1), ("low-latitude", 2), ("southern", 1), ("southern", 2)] {
        let d = data(site, seed);
        let o = evaluate_options(&d, &Variant::Full.options()).expect("chain");
        assert!(o.heading_rms_deg <= TARGET_DEG, "{site} seed {seed}: {o:?}");
        let ratio = o.observed_over_predicted.expect("a prediction");
        assert!((0.5..=2.0).contains(&ratio), "{site} seed {seed}: observed/predicted {ratio}");
        ratios.push(ratio);
    }
    // One run's ratio is one draw; the pool over the four is held to
    // 0.7–1.4, as the joint back-stepping's prediction is (measured: RMS of
    // the ratios 1.035).
    let pooled = (ratios.iter().map(|r| r * r).sum::<f64>() / ratios.len() as f64).sqrt();
    eprintln!("observed / predicted: {ratios:?}, pooled {pooled:.3}");
    assert!((0.7..=1.4).contains(&pooled), "{pooled}: {ratios:?}");
}

#[test]
fn at_high_latitude_what_is_left_beyond_the_white_noise_is_small() {
    // At inclination 75° the AHRS's 0.15° roll/pitch noise alone makes
    // ~0.55° of white heading noise (tan I = 3.7), which no calibration
    // removes; the calibration's own part is judged. Measured: heading RMS
    // 0.578°, white noise 0.555°, systematic 0.16°, observed/predicted 1.04.
    let d = data("high-latitude", 2);
    let o = evaluate_options(&d, &Variant::Full.options()).expect("chain");
    assert!(o.heading_systematic_deg <= TARGET_DEG, "{o:?}");
    let ratio = o.observed_over_predicted.expect("a prediction");
    assert!((0.5..=2.0).contains(&ratio), "observed/predicted {ratio}");
}

#[test]
fn the_field_gradient_along_the_track_is_the_true_fields() {
    let d = data("low-latitude", 3);
    let chain: Chain = compute::calibrate(&d.swing.recording, &d.run.recording, &d.swing.truth.site, &Variant::Full.options()).expect("chain");
    let joint = chain.backstep.joint.as_ref().expect("joint solution");
    assert!(joint.gradient_estimated, "{:?}", joint.notes);
    let truth = true_gradient(&d.run, joint.track_direction);
    let est = joint.field_gradient_nt_per_m;
    eprintln!("gradient along the track: estimated {est:?} ± {:?}, true {truth:?} nT/m", joint.sigma.gradient_nt_per_m);
    // Measured: ∂H/∂s −0.0235 nT/m (true −0.0235), ∂Z/∂s −0.0094 (true
    // −0.0088), σ 0.0005 each.
    for k in 0..2 {
        assert!((est[k] - truth[k]).abs() <= 0.2 * truth[k].abs() + 0.001, "component {k}: estimated {est:?}, true {truth:?}");
    }
    // Without it the same data give a worse heading.
    let without = evaluate_options(&d, &Variant::NoFieldGradient.options()).expect("chain");
    let with = evaluate_options(&d, &Variant::Full.options()).expect("chain");
    assert!(with.heading_rms_deg < without.heading_rms_deg, "with {:.3}°, without {:.3}°", with.heading_rms_deg, without.heading_rms_deg);
}
