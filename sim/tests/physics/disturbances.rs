//! The disturbances for integrity checks — a steel structure passed
//! at a few metres and a payload switched on mid-run — checked against
//! physics written here independently of the simulator's code.

use magcal_sim::effects::{induced_magnetisation_a_per_m, prolate_demag_axial, Effect, Effects, Payload, SteelSegment, SteelStructure};
use magcal_sim::field_test::{self, paper_site, FieldTest, RunKind, RunParams, SensorModel, Simulation};
use magcal_sim::scenario::effects_runs;

/// μ0 = 4π·10⁻⁷ T·m/A, written out here.
const MU0: f64 = 4.0 * std::f64::consts::PI * 1e-7;

fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// |B| of a dipole at distance r and angle θ from its axis (textbook:
/// `μ0 m / (4π r³) · √(1 + 3 cos²θ)`), nT.
fn dipole_magnitude_nt(m_am2: f64, r_m: f64, cos_theta: f64) -> f64 {
    MU0 / (4.0 * std::f64::consts::PI) * m_am2 / r_m.powi(3) * (1.0 + 3.0 * cos_theta * cos_theta).sqrt() * 1e9
}

/// A sphere of susceptibility χ in a uniform field H carries the moment
/// `3χ/(3 + χ)·V·H` (demagnetising factor 1/3), for weak and strong χ.
#[test]
fn a_steel_sphere_takes_the_textbook_induced_moment() {
    let ambient_nt = [27_000.0, 2_000.0, 40_000.0];
    for chi in [0.5, 200.0] {
        let volume_m3 = 0.8;
        let sphere = SteelSegment { north_m: 0.0, east_m: 0.0, depth_m: 0.0, volume_m3, axis_ned: [0.6, 0.0, 0.8], demag_axial: 1.0 / 3.0, permanent_a_per_m: [0.0; 3] };
        let body = SteelStructure { susceptibility: chi, segments: vec![sphere] };
        let m = body.moment_am2(&sphere, ambient_nt);
        for k in 0..3 {
            let h = ambient_nt[k] * 1e-9 / MU0;
            let want = 3.0 * chi / (3.0 + chi) * volume_m3 * h;
            assert!((m[k] - want).abs() < 1e-9 * want.abs().max(1.0), "χ {chi}: {m:?} vs {want} on axis {k}");
        }
    }
    // One axis at a time, the same formula with N = 1/3.
    assert!((induced_magnetisation_a_per_m(200.0, 1.0 / 3.0, 10.0) - 600.0 / 203.0 * 10.0).abs() < 1e-12);
}

/// Osborn (1945), Table I: the demagnetising factor along the axis of a
/// prolate spheroid, aspect ratio 2 → 0.1736, 5 → 0.0558, 10 → 0.0203,
/// and 1/3 for the sphere.
#[test]
fn the_prolate_demagnetising_factor_matches_osborns_table() {
    for (aspect, want) in [(1.0, 1.0 / 3.0), (2.0, 0.1736), (5.0, 0.0558), (10.0, 0.0203)] {
        let got = prolate_demag_axial(aspect);
        assert!((got - want).abs() < 1e-4, "aspect {aspect}: {got} vs {want}");
    }
}

/// A segment magnetised along its axis (the pier's piles: vertical) has
/// on that axis the field `2m·μ0/(4π r³)` and at its equator half of it,
/// opposite: the structure's field sums its segments' dipoles.
#[test]
fn a_structure_of_one_segment_has_the_dipole_field_on_axis_and_equator() {
    let seg = SteelSegment { north_m: 10.0, east_m: -5.0, depth_m: 4.0, volume_m3: 0.1, axis_ned: [0.0, 0.0, 1.0], demag_axial: 0.01, permanent_a_per_m: [0.0, 0.0, 1000.0] };
    let body = SteelStructure { susceptibility: 0.0, segments: vec![seg] };
    // χ = 0: only the permanent moment, 100 A·m² down.
    let m = 100.0;
    let r = 3.0;
    let k = MU0 / (4.0 * std::f64::consts::PI) * m / (r * r * r) * 1e9;
    let below = body.field_nt([10.0, -5.0, 4.0 + r], [0.0, 0.0, 45_000.0]);
    let beside = body.field_nt([10.0 + r, -5.0, 4.0], [0.0, 0.0, 45_000.0]);
    assert!((below[2] - 2.0 * k).abs() < 1e-9 && below[0].abs() < 1e-9, "{below:?} vs {}", 2.0 * k);
    assert!((beside[2] + k).abs() < 1e-9 && beside[0].abs() < 1e-9, "{beside:?} vs {}", -k);
    assert!((body.distance_m([10.0 + r, -5.0, 4.0]) - r).abs() < 1e-12);
}

fn effects_validation(effects: &Effects, seed: u64) -> Simulation {
    let (_, validation) = effects_runs();
    field_test::run_with(&SensorModel::paper_like(), &paper_site(), &validation, seed, 2.0, RunKind::Validation, effects).unwrap()
}

/// The pier on the validation run: the vehicle passes it at 2–10 m and
/// the sensor sees hundreds of nT there; far from it the field is the
/// structure's total moment as one dipole (1/r³); the counts away from it
/// are the effect-free run's.
#[test]
fn the_validation_run_passes_the_pier_at_a_few_metres() {
    let pier = Effects::of(&[Effect::Structure]);
    let sim = effects_validation(&pier, 201);
    let plain = effects_validation(&Effects::none(), 201);
    let truth = sim.truth.effects.as_ref().unwrap().structure.clone().unwrap();
    eprintln!("closest {:.2} m at {:.0} s, peak {:.0} nT", truth.closest_m, truth.closest_t_s, truth.peak_disturbance_nt);
    assert!((2.0..=10.0).contains(&truth.closest_m), "{truth:?}");
    // Measured: 2.62 m, 3 270 nT.
    assert!((1500.0..=8000.0).contains(&truth.peak_disturbance_nt), "{truth:?}");
    let distance = sim.effect_column("structure_distance_m").unwrap();
    let disturbance = sim.effect_column("truth_disturbance_nt").unwrap();
    // Far field: the sum of the segments' moments at the pier's centre.
    let s = SteelStructure::pier_beside_validation();
    let f = host_tools::geomag::igrf14(36.9 - 0.008, 50.6 + 0.006, 0.0, 2021.0).unwrap();
    let ambient = [f.north_nt, f.east_nt, f.down_nt];
    let total = s.segments.iter().map(|g| s.moment_am2(g, ambient)).fold([0.0; 3], |a, m| [a[0] + m[0], a[1] + m[1], a[2] + m[2]]);
    let n = s.segments.len() as f64;
    let centre = [s.segments.iter().map(|g| g.north_m).sum::<f64>() / n, s.segments.iter().map(|g| g.east_m).sum::<f64>() / n, s.segments.iter().map(|g| g.depth_m).sum::<f64>() / n];
    let lat = sim.recording.lat_deg.as_ref().unwrap();
    let lon = sim.recording.lon_deg.as_ref().unwrap();
    let depth = sim.effect_column("depth_m").unwrap();
    let mut checked = 0;
    for i in 0..sim.recording.len() {
        if (200.0..400.0).contains(&distance[i]) {
            // The validation run without the current effect logs its true track.
            let p = [(lat[i] - 36.9) * 111_320.0, (lon[i] - 50.6) * 111_320.0 * lat[i].to_radians().cos()];
            let r = [p[0] - centre[0], p[1] - centre[1], depth[i] - centre[2]];
            let rn = norm(r);
            let cos_theta = (r[0] * total[0] + r[1] * total[1] + r[2] * total[2]) / (rn * norm(total));
            let want = dipole_magnitude_nt(norm(total), rn, cos_theta);
            // The pier's extent (28 m × 4 m × 20 m) against 200–400 m: a
            // quadrupole part of ≲ 1 %.
            assert!((disturbance[i] / want - 1.0).abs() < 0.03, "row {i}: {} vs {want} nT at {rn:.0} m", disturbance[i]);
            checked += 1;
        }
    }
    assert!(checked > 100, "{checked}");
    // Away from the pier (> 500 m) the counts are the effect-free run's.
    let mut far = 0;
    for (i, (got, want)) in sim.recording.mag.iter().zip(&plain.recording.mag).enumerate() {
        if distance[i] > 500.0 {
            far += 1;
            assert!((0..3).all(|k| (got[k] - want[k]).abs() <= 1.0), "row {i}");
        }
    }
    assert!(far > sim.recording.len() / 2);
    // The swing test and the calibration run never come near it.
    let (run, _) = effects_runs();
    let cal = field_test::run_with(&SensorModel::paper_like(), &paper_site(), &run, 101, 1.0, RunKind::Run, &pier).unwrap();
    let swing = field_test::swing_with(&SensorModel::paper_like(), &paper_site(), 1, 1.0, 55.0, 10.0, &pier).unwrap();
    for sim in [&cal, &swing] {
        let worst = sim.effect_column("truth_disturbance_nt").unwrap().iter().copied().fold(0.0, f64::max);
        assert!(worst < 0.01, "{:?}: {worst} nT", sim.truth.scenario);
    }
    // On paper 000's validation run (2 m/s, deeper dives) too.
    let paper = field_test::run_with(&SensorModel::paper_like(), &paper_site(), &RunParams::validation(), 201, 2.0, RunKind::Validation, &pier).unwrap();
    let t = paper.truth.effects.unwrap().structure.unwrap();
    eprintln!("paper's validation: closest {:.2} m, peak {:.0} nT", t.closest_m, t.peak_disturbance_nt);
    assert!((2.0..=10.0).contains(&t.closest_m), "{t:?}");
}

/// The payload: before it is switched on the rows are the effect-free
/// run's; after, every count moves by `D·B` (the sensor's gain times the
/// dipole's field at the sensor, `|B|` from the textbook magnitude), and
/// `truth_disturbance_nt` is `|B|`.
#[test]
fn a_payload_switched_on_moves_the_hard_iron_from_that_moment() {
    let payload = Effects::of(&[Effect::Payload]);
    let sim = effects_validation(&payload, 203);
    let plain = effects_validation(&Effects::none(), 203);
    let p = Payload::motor_on_validation();
    let r = norm(p.position_m);
    let cos_theta = -(p.position_m[0] * p.moment_am2[0] + p.position_m[1] * p.moment_am2[1] + p.position_m[2] * p.moment_am2[2]) / (r * norm(p.moment_am2));
    let want_nt = dipole_magnitude_nt(norm(p.moment_am2), r, cos_theta);
    eprintln!("payload |B| {want_nt:.0} nT");
    assert!((300.0..=5000.0).contains(&want_nt));
    let truth = sim.truth.effects.as_ref().unwrap().payload.clone().unwrap();
    assert_eq!(truth.on_at_s, Some(1800.0));
    let d = SensorModel::paper_like().gain_raw_per_nt;
    let b = p.field_nt();
    assert!((norm(b) - want_nt).abs() < 1e-9 * want_nt);
    let shift = [0, 1, 2].map(|i| d[i][0] * b[0] + d[i][1] * b[1] + d[i][2] * b[2]);
    let t = sim.recording.t_s.as_ref().unwrap();
    let on = sim.effect_column("payload_on").unwrap();
    let disturbance = sim.effect_column("truth_disturbance_nt").unwrap();
    for i in 0..sim.recording.len() {
        let after = t[i] >= 1800.0;
        assert_eq!(on[i] == 1.0, after);
        assert!((disturbance[i] - if after { want_nt } else { 0.0 }).abs() < 1e-6, "row {i}");
        for (k, shift_k) in shift.iter().enumerate() {
            let moved = sim.recording.mag[i][k] - plain.recording.mag[i][k];
            let want = if after { *shift_k } else { 0.0 };
            // Rounding to whole counts: within one count.
            assert!((moved - want).abs() <= 1.0, "row {i} axis {k}: {moved} vs {want}");
        }
    }
    // Not in the other field tests.
    let swing = field_test::swing_with(&SensorModel::paper_like(), &paper_site(), 3, 1.0, 55.0, 10.0, &payload).unwrap();
    assert!(swing.effect_column("truth_disturbance_nt").unwrap().iter().all(|&v| v == 0.0));
    assert_eq!(swing.truth.effects.unwrap().payload.unwrap().on_at_s, None);
    assert_eq!(p.field_test, FieldTest::Validation);
}

/// `--effects` names: `all` stays the five calibration effects; the
/// disturbances join by name.
#[test]
fn the_disturbances_are_named_and_not_in_all() {
    assert_eq!(Effects::parse("all").unwrap().list(), Effect::ALL.to_vec());
    let e = Effects::parse("all,structure,payload").unwrap();
    assert_eq!(e.list().len(), 7);
    assert!(e.structure.is_some() && e.payload.is_some());
    assert_eq!(Effects::parse("payload").unwrap().list(), vec![Effect::Payload]);
}
