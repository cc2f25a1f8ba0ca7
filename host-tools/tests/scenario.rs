//! Paper 000's field test, simulated end to end with ground truth: swing
//! test → axis fit against IGRF → back-stepping on an out-and-back run (the
//! paper's and ours) → swing (Fourier) fit against the delayed GPS course →
//! true-heading error on a separate validation run.

use calib_core::cal::ModelKind;
use calib_core::heading::wrap_pi;
use host_tools::caldoc::CalDoc;
use host_tools::pipeline::{self, BackstepMethod, BackstepOptions, Delay, FitOptions, RunReference};
use host_tools::sim::{self, RunParams, SensorModel, Simulation, Site};

/// True-heading RMS error (degrees) of a calibration on a simulated run.
fn heading_rms_deg(doc: &CalDoc, sim: &Simulation) -> f64 {
    let cal = doc.calibration();
    let rec = &sim.recording;
    let (roll, pitch) = (rec.roll_deg.as_ref().unwrap(), rec.pitch_deg.as_ref().unwrap());
    let mut ss = 0.0;
    for i in 0..rec.len() {
        let out = cal.apply(rec.mag[i], roll[i].to_radians(), pitch[i].to_radians());
        let e = wrap_pi(out.true_heading_rad - sim.true_heading_deg[i].to_radians());
        ss += e * e;
    }
    (ss / rec.len() as f64).sqrt().to_degrees()
}

/// RMS of |h| − IGRF over a simulated run, nT.
fn field_error_nt(doc: &CalDoc, sim: &Simulation) -> f64 {
    let cal = doc.field_cal();
    let rec = &sim.recording;
    let (lat, lon) = (rec.lat_deg.as_ref().unwrap(), rec.lon_deg.as_ref().unwrap());
    let mut ss = 0.0;
    for i in (0..rec.len()).step_by(10) {
        let f = host_tools::igrf::igrf14(lat[i], lon[i], 0.0, sim.truth.site.year).unwrap().total_nt();
        let h = cal.apply(rec.mag[i]);
        let e = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt() - f;
        ss += e * e;
    }
    (ss / (rec.len() / 10) as f64).sqrt()
}

struct Outcome {
    step_sphere: f64,
    step_paper: f64,
    step_ours: f64,
    heading_sphere: f64,
    heading_paper: f64,
    heading_ours: f64,
    field_paper: f64,
    field_ours: f64,
    delay_ours: f64,
}

fn scenario(name: &str, sensor: SensorModel, seed: u64) -> Outcome {
    let site = Site::paper_like();
    let swing = sim::swing(&sensor, &site, seed, 5.0).unwrap();
    let run = sim::run(&sensor, &site, &RunParams::paper_like(), seed + 100, 2.0, "run").unwrap();
    let validation = sim::run(&sensor, &site, &RunParams::validation(), seed + 200, 2.0, "validation").unwrap();
    let field = host_tools::igrf::igrf14(site.lat_deg, site.lon_deg, 0.0, site.year).unwrap();

    // Step 1: the paper's axis fit on the swing test.
    let mut step1 = pipeline::fit_recording(&swing.recording, &FitOptions { model: ModelKind::Axis, field_nt: field.total_nt(), saturation: None, allow_weak: false }).unwrap();
    step1.declination_deg = Some(field.declination_deg());
    let reference = RunReference::Igrf { lat_deg: site.lat_deg, lon_deg: site.lon_deg, year: site.year };

    let mut paper_opts = BackstepOptions::new(reference);
    paper_opts.method = BackstepMethod::Paper;
    let (paper, paper_rep) = pipeline::backstep_recording(&run.recording, &step1, &paper_opts).unwrap();
    let mut ours_opts = BackstepOptions::new(reference);
    ours_opts.swing = Some((swing.recording.mag.clone(), field.total_nt()));
    let (ours, ours_rep) = pipeline::backstep_recording(&run.recording, &step1, &ours_opts).unwrap();

    let delay = Delay::Estimate { max_s: 5.0 };
    let (sphere_sw, _, _) = pipeline::swing_recording(&run.recording, &step1, delay).unwrap();
    let (paper_sw, _, _) = pipeline::swing_recording(&run.recording, &paper, delay).unwrap();
    let (ours_sw, _, d) = pipeline::swing_recording(&run.recording, &ours, delay).unwrap();
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

/// Issue 4's acceptance on the paper-like scenario (thrusters add a mostly
/// horizontal running bias): the paper's back-stepping removes the step as
/// in its Table 6; ours removes it further and gives the better heading.
#[test]
fn paper_like_scenario_meets_the_acceptance_numbers() {
    for seed in [1, 2, 3] {
        let o = scenario("paper-like", SensorModel::paper_like(), seed);
        assert!(o.step_sphere.abs() >= 300.0, "the sphere fit must leave a paper-like step");
        assert!(o.step_paper.abs() <= 20.0);
        assert!(o.step_ours.abs() <= 5.0);
        assert!(o.heading_ours <= 0.5);
        assert!(o.heading_ours < o.heading_paper);
        assert!(o.field_ours <= 50.0);
        assert!((o.delay_ours - 2.0).abs() < 0.3);
    }
}

/// A hull that couples the vertical channel to the horizontal ones: the
/// step is not one a change of `sz` removes; ours still does.
#[test]
fn hull_coupled_scenario_defeats_the_papers_sz_search_but_not_ours() {
    for seed in [4, 5] {
        let o = scenario("hull-coupled", SensorModel::hull_coupled(), seed);
        assert!(o.step_sphere.abs() >= 300.0);
        assert!(o.step_paper.abs() > 100.0, "the paper's correction cannot remove this step");
        assert!(o.step_ours.abs() <= 5.0);
        assert!(o.heading_ours <= 0.5);
        assert!(o.field_ours <= 50.0);
    }
}
