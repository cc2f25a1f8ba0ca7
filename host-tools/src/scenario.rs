//! Paper 000's field test, simulated end to end with ground truth: swing
//! test → axis fit against IGRF → back-stepping on an out-and-back run (the
//! paper's and ours) → swing (Fourier) fit against the delayed GPS course →
//! true-heading and field errors on a separate validation run. Used by the
//! acceptance tests and by `cargo xtask bench`.
//!
//! `Outcome` fields: the turnaround step (nT) with the sphere (axis) fit, after
//! the paper's back-stepping and after ours; the validation run's true-heading
//! RMS (degrees) for the three chains, each finished by a swing fit; the
//! validation run's |F| − IGRF RMS (nT) after the paper's and our
//! back-stepping; the GPS delay our chain estimated (s).

use calib_core::cal::ModelKind;
use calib_core::heading::wrap_pi;

use crate::caldoc::CalDoc;
use crate::pipeline::{self, BackstepMethod, BackstepOptions, Delay, FitOptions, RunReference};
use crate::sim::{self, RunParams, SensorModel, Simulation, Site};

/// True-heading RMS error (degrees) of a calibration on a simulated run.
pub fn heading_rms_deg(doc: &CalDoc, sim: &Simulation) -> f64 {
    let cal = doc.calibration();
    let rec = &sim.recording;
    let (roll, pitch) = (rec.roll_deg.as_ref().expect("simulated scenario"), rec.pitch_deg.as_ref().expect("simulated scenario"));
    let mut ss = 0.0;
    for i in 0..rec.len() {
        let out = cal.apply(rec.mag[i], roll[i].to_radians(), pitch[i].to_radians());
        let e = wrap_pi(out.true_heading_rad - sim.true_heading_deg[i].to_radians());
        ss += e * e;
    }
    (ss / rec.len() as f64).sqrt().to_degrees()
}

/// RMS of |h| − IGRF over a simulated run, nT.
pub fn field_error_nt(doc: &CalDoc, sim: &Simulation) -> f64 {
    let cal = doc.field_cal();
    let rec = &sim.recording;
    let (lat, lon) = (rec.lat_deg.as_ref().expect("simulated scenario"), rec.lon_deg.as_ref().expect("simulated scenario"));
    let mut ss = 0.0;
    for i in (0..rec.len()).step_by(10) {
        let f = crate::igrf::igrf14(lat[i], lon[i], 0.0, sim.truth.site.year).expect("simulated scenario").total_nt();
        let h = cal.apply(rec.mag[i]);
        let e = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt() - f;
        ss += e * e;
    }
    (ss / (rec.len() / 10) as f64).sqrt()
}

/// What the chain achieved on one simulated field test.
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct Outcome {
    /// See the module docs.
    pub step_sphere: f64,
    /// See the module docs.
    pub step_paper: f64,
    /// See the module docs.
    pub step_ours: f64,
    /// See the module docs.
    pub heading_sphere: f64,
    /// See the module docs.
    pub heading_paper: f64,
    /// See the module docs.
    pub heading_ours: f64,
    /// See the module docs.
    pub field_paper: f64,
    /// See the module docs.
    pub field_ours: f64,
    /// See the module docs.
    pub delay_ours: f64,
}

/// Runs the whole chain on a simulated vehicle: swing test, axis fit, both
/// back-steppings, swing fits, validation.
///
/// # Panics
/// If a step of the chain fails on the simulated data (a bug, which the
/// acceptance tests are there to catch).
pub fn evaluate(name: &str, sensor: SensorModel, seed: u64) -> Outcome {
    let site = Site::paper_like();
    let swing = sim::swing(&sensor, &site, seed, 5.0).expect("simulated scenario");
    let run = sim::run(&sensor, &site, &RunParams::paper_like(), seed + 100, 2.0, "run").expect("simulated scenario");
    let validation = sim::run(&sensor, &site, &RunParams::validation(), seed + 200, 2.0, "validation").expect("simulated scenario");
    let field = crate::igrf::igrf14(site.lat_deg, site.lon_deg, 0.0, site.year).expect("simulated scenario");

    // Step 1: the paper's axis fit on the swing test.
    let mut step1 = pipeline::fit_recording(&swing.recording, &FitOptions { model: ModelKind::Axis, field_nt: field.total_nt(), saturation: None, allow_weak: false }).expect("simulated scenario");
    step1.declination_deg = Some(field.declination_deg());
    let reference = RunReference::Igrf { lat_deg: site.lat_deg, lon_deg: site.lon_deg, year: site.year };

    let mut paper_opts = BackstepOptions::new(reference);
    paper_opts.method = BackstepMethod::Paper;
    let (paper, paper_rep) = pipeline::backstep_recording(&run.recording, &step1, &paper_opts).expect("simulated scenario");
    let mut ours_opts = BackstepOptions::new(reference);
    ours_opts.swing = Some((swing.recording.mag.clone(), field.total_nt()));
    let (ours, ours_rep) = pipeline::backstep_recording(&run.recording, &step1, &ours_opts).expect("simulated scenario");

    let delay = Delay::Estimate { max_s: 5.0 };
    let (sphere_sw, _, _) = pipeline::swing_recording(&run.recording, &step1, delay).expect("simulated scenario");
    let (paper_sw, _, _) = pipeline::swing_recording(&run.recording, &paper, delay).expect("simulated scenario");
    let (ours_sw, _, d) = pipeline::swing_recording(&run.recording, &ours, delay).expect("simulated scenario");
    let o = Outcome {
        step_sphere: paper_rep.before.step_nt,
        step_paper: paper_rep.after.step_nt,
        step_ours: ours_rep.after.step_nt,
        heading_sphere: heading_rms_deg(&sphere_sw, &validation),
        heading_paper: heading_rms_deg(&paper_sw, &validation),
        heading_ours: heading_rms_deg(&ours_sw, &validation),
        field_paper: field_error_nt(&paper, &validation),
        field_ours: field_error_nt(&ours, &validation),
        delay_ours: d,
    };
    eprintln!(
        "{name} seed {seed}: turnaround step {:.0} nT (sphere fit) → {:.1} (paper) / {:.1} (ours); validation true-heading RMS {:.2}° / {:.2}° / {:.2}°; field error vs IGRF {:.1} / {:.1} nT (paper / ours); GPS delay {:.2} s",
        o.step_sphere, o.step_paper, o.step_ours, o.heading_sphere, o.heading_paper, o.heading_ours, o.field_paper, o.field_ours, o.delay_ours
    );
    o
}

