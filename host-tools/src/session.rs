//! The calibration session: the paper's field procedure driven over the
//! serial link.
//!
//! 1. **Swing test** — the vehicle is turned (by a diver) while the board
//!    streams raw samples and runs its on-board fit; the session tracks the
//!    attitudes and field directions covered and says what is missing.
//! 2. **Out-and-back run** — recorded the same way, with the GPS course.
//! 3. **Computation** on the host: axis fit against IGRF (step 1), our
//!    back-stepping (with the swing test's magnitudes), swing fit against the
//!    delayed GPS course.
//! 4. **Upload**: unlock, stage, commit, read back and compare — resumed over
//!    a reconnect if the link drops; the board never runs unverified
//!    coefficients (it only switches after a CRC-checked commit).
//! 5. Everything is saved in a directory (recordings, settings, results,
//!    report) so `magcal fit/backstep/swing` reproduce the numbers offline.
//!
//! The vehicle is a [`Vehicle`]: for the demo, [`SimVehicle`] plays the
//! simulator's field test into the QEMU board (USART2 bridges, USART1
//! attitude) in lock-step with the board's samples.

use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use calib_core::cal::ModelKind;
use calib_core::heading::wrap_pi;
use magcal_protocol::{Coefficients, FitModel, FitReport, StreamMode};
use serde_json::json;

use crate::caldoc::CalDoc;
use crate::link::{FeedWriter, Link, LinkError};
use crate::pipeline::{self, BackstepOptions, Delay, FitOptions, PipelineError, RunReference};
use crate::recording::Recording;
use crate::sim::Simulation;

/// Why a session stopped.
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    /// The link failed.
    #[error("link: {0}")]
    Link(#[from] LinkError),
    /// A computation refused the data.
    #[error("{0}")]
    Pipeline(#[from] PipelineError),
    /// The board stopped answering a step.
    #[error("no sample from the board for step {step} within {timeout_ms} ms")]
    NoSample {
        /// Step index.
        step: usize,
        /// Timeout.
        timeout_ms: u64,
    },
    /// The swing test did not cover enough attitudes.
    #[error("swing test incomplete: {0}")]
    Coverage(String),
    /// Files could not be written.
    #[error("{0}")]
    Io(String),
    /// The coefficients could not be verified on the board.
    #[error("coefficients not verified after {0} attempts")]
    NotVerified(u32),
}

/// The host-side columns of one step (the board supplies the field).
#[derive(Debug, Clone, Copy)]
pub struct Step {
    /// Time, s.
    pub t_s: f64,
    /// AHRS roll, degrees.
    pub roll_deg: f64,
    /// AHRS pitch, degrees.
    pub pitch_deg: f64,
    /// GPS course, degrees true (NaN when not available).
    pub ref_heading_deg: f64,
    /// Position.
    pub lat_deg: f64,
    /// Position.
    pub lon_deg: f64,
    /// The sensor-feed frame the board must have seen (simulated vehicle).
    pub feed_seq: Option<u32>,
}

/// A source of steps: applies each step's stimulus to the board (simulated)
/// or waits for the vehicle's next navigation record (real).
pub trait Vehicle {
    /// The next step, `None` when the manoeuvre is over.
    fn next_step(&mut self) -> Result<Option<Step>, LinkError>;
    /// Steps in the manoeuvre, when known (for progress).
    fn len_hint(&self) -> Option<usize>;
    /// Applies the current step's stimulus again (it may have been lost).
    fn repeat(&mut self) -> Result<(), LinkError> {
        Ok(())
    }
}

/// The simulator's field test played into the QEMU board.
pub struct SimVehicle<'a, W> {
    sim: &'a Simulation,
    feed: &'a mut FeedWriter<W>,
    next: usize,
    /// Bridge offsets the QEMU ADC model adds (removed by set/reset).
    pub bridge_offsets: [f32; 3],
}

impl<'a, W: Write> SimVehicle<'a, W> {
    /// Plays `sim` (its `mag` column must be the field at the bridges in nT).
    pub fn new(sim: &'a Simulation, feed: &'a mut FeedWriter<W>) -> Self {
        Self { sim, feed, next: 0, bridge_offsets: [120_000.0, -95_000.0, 33_000.0] }
    }
}

impl<W: Write> Vehicle for SimVehicle<'_, W> {
    fn next_step(&mut self) -> Result<Option<Step>, LinkError> {
        let r = &self.sim.recording;
        let i = self.next;
        if i >= r.len() {
            return Ok(None);
        }
        self.next += 1;
        let col = |c: &Option<Vec<f64>>| c.as_ref().and_then(|v| v.get(i).copied()).unwrap_or(f64::NAN);
        let seq = self.feed.send(r.mag[i].map(|v| v as f32), self.bridge_offsets)?;
        Ok(Some(Step {
            t_s: col(&r.t_s),
            roll_deg: col(&r.roll_deg),
            pitch_deg: col(&r.pitch_deg),
            ref_heading_deg: col(&r.ref_heading_deg),
            lat_deg: col(&r.lat_deg),
            lon_deg: col(&r.lon_deg),
            feed_seq: Some(seq),
        }))
    }
    fn len_hint(&self) -> Option<usize> {
        Some(self.sim.recording.len())
    }
    fn repeat(&mut self) -> Result<(), LinkError> {
        self.feed.resend()
    }
}

/// A real vehicle: its navigation (AHRS attitude, GPS course, position)
/// arrives as CSV lines in the INTERFACES.md columns (`t, roll_deg,
/// pitch_deg, ref_heading_deg, lat_deg, lon_deg`) from a file, a FIFO or
/// stdin, one line per step; the board's next sample is paired with each.
pub struct NavVehicle<R> {
    lines: std::io::Lines<R>,
    columns: [Option<usize>; 6],
    line_no: usize,
}

impl<R: std::io::BufRead> NavVehicle<R> {
    /// Reads the header; `t`, `roll_deg` and `pitch_deg` are required.
    pub fn new(reader: R) -> Result<Self, SessionError> {
        let mut lines = reader.lines();
        let header = lines.next().ok_or_else(|| SessionError::Io("navigation stream: empty (expected a header)".into()))?.map_err(|e| SessionError::Io(e.to_string()))?;
        let names: Vec<String> = header.split(',').map(|h| h.trim().to_ascii_lowercase()).collect();
        let find = |n: &str| names.iter().position(|h| h == n);
        let columns = ["t", "roll_deg", "pitch_deg", "ref_heading_deg", "lat_deg", "lon_deg"].map(find);
        for (k, name) in ["t", "roll_deg", "pitch_deg"].iter().enumerate() {
            if columns[k].is_none() {
                return Err(SessionError::Io(format!("navigation stream: missing column `{name}` (the header has: {header})")));
            }
        }
        Ok(Self { lines, columns, line_no: 1 })
    }
}

impl<R: std::io::BufRead> Vehicle for NavVehicle<R> {
    fn next_step(&mut self) -> Result<Option<Step>, LinkError> {
        loop {
            let Some(line) = self.lines.next() else { return Ok(None) };
            self.line_no += 1;
            let line = line?;
            if line.trim().is_empty() {
                continue;
            }
            let cells: Vec<&str> = line.split(',').collect();
            let cell = |k: usize| self.columns[k].and_then(|i| cells.get(i)).map_or(Some(f64::NAN), |c| crate::recording::parse_cell(c));
            let values: Option<Vec<f64>> = (0..6).map(cell).collect();
            match values {
                Some(v) if v[0].is_finite() => {
                    return Ok(Some(Step { t_s: v[0], roll_deg: v[1], pitch_deg: v[2], ref_heading_deg: v[3], lat_deg: v[4], lon_deg: v[5], feed_seq: None }))
                }
                _ => eprintln!("  navigation line {} skipped: not numbers: {line}", self.line_no),
            }
        }
    }
    fn len_hint(&self) -> Option<usize> {
        None
    }
}

/// What the swing test has covered.
#[derive(Debug, Clone, Default)]
pub struct SwingCoverage {
    sectors: [u32; 12],
    roll: (f64, f64),
    pitch: (f64, f64),
    /// The on-board fit's last report.
    pub fit: Option<FitReport>,
}

/// Roll the paper's swing test reaches (±55°); the gate asks for ±40°.
pub const ROLL_GATE_DEG: f64 = 40.0;
/// Pitch the swing test reaches (±10°); the gate asks for ±7°.
pub const PITCH_GATE_DEG: f64 = 7.0;
const COMPASS: [&str; 12] = ["north", "north-north-east", "east-north-east", "east", "east-south-east", "south-south-east", "south", "south-south-west", "west-south-west", "west", "west-north-west", "north-north-west"];

impl SwingCoverage {
    /// Adds an attitude and the heading measured with the current coefficients.
    pub fn add(&mut self, roll_deg: f64, pitch_deg: f64, heading_deg: f64) {
        if heading_deg.is_finite() {
            let s = (heading_deg.rem_euclid(360.0) / 30.0) as usize;
            if let Some(c) = self.sectors.get_mut(s.min(11)) {
                *c += 1;
            }
        }
        if roll_deg.is_finite() {
            self.roll = (self.roll.0.min(roll_deg), self.roll.1.max(roll_deg));
        }
        if pitch_deg.is_finite() {
            self.pitch = (self.pitch.0.min(pitch_deg), self.pitch.1.max(pitch_deg));
        }
    }

    /// Plain guidance: what the operator must still do. Empty when done.
    pub fn guidance(&self) -> Vec<String> {
        let mut out = Vec::new();
        if self.roll.1 < ROLL_GATE_DEG {
            out.push(format!("roll further to starboard (reached {:.0}°, need {ROLL_GATE_DEG:.0}°)", self.roll.1));
        }
        if self.roll.0 > -ROLL_GATE_DEG {
            out.push(format!("roll further to port (reached {:.0}°, need −{ROLL_GATE_DEG:.0}°)", self.roll.0));
        }
        if self.pitch.1 < PITCH_GATE_DEG {
            out.push(format!("pitch nose up further (reached {:.0}°, need {PITCH_GATE_DEG:.0}°)", self.pitch.1));
        }
        if self.pitch.0 > -PITCH_GATE_DEG {
            out.push(format!("pitch nose down further (reached {:.0}°, need −{PITCH_GATE_DEG:.0}°)", self.pitch.0));
        }
        let missing: Vec<&str> = self.sectors.iter().zip(COMPASS).filter(|(c, _)| **c < 3).map(|(_, n)| n).collect();
        if !missing.is_empty() {
            out.push(format!("turn through {}", missing.join(", ")));
        }
        out
    }

    /// Sectors visited (of 12).
    pub fn sectors_visited(&self) -> usize {
        self.sectors.iter().filter(|c| **c >= 3).count()
    }
}

/// Records a manoeuvre: per step, sends the AHRS attitude to the board (when
/// its heading output is wanted) and takes the board's sample for that step
/// (lock-step with the simulated feed), returning the recording in the
/// INTERFACES.md format. The recording's roll and pitch are the AHRS's.
pub fn record<P: Read + Write>(
    link: &mut Link<P>,
    vehicle: &mut impl Vehicle,
    send_attitude: bool,
    on_step: impl FnMut(usize, &Step, &magcal_protocol::Sample, &mut Link<P>) -> Result<(), SessionError>,
) -> Result<(Recording, Vec<magcal_protocol::Sample>), SessionError> {
    record_resuming(link, vehicle, send_attitude, None, on_step)
}

/// How to get the link back when it drops mid-recording.
pub struct Resume<'a, P> {
    /// Opens the link again.
    pub connect: &'a mut dyn FnMut() -> Result<Link<P>, LinkError>,
    /// What the board streams (set again after reconnecting).
    pub stream: StreamMode,
    /// Attempts per drop.
    pub attempts: u32,
}

/// [`record`], reconnecting when the link drops: the steps lost meanwhile
/// are kept as rows without a field (NaN) and counted, never invented.
pub fn record_resuming<P: Read + Write>(
    link: &mut Link<P>,
    vehicle: &mut impl Vehicle,
    send_attitude: bool,
    mut resume: Option<Resume<'_, P>>,
    mut on_step: impl FnMut(usize, &Step, &magcal_protocol::Sample, &mut Link<P>) -> Result<(), SessionError>,
) -> Result<(Recording, Vec<magcal_protocol::Sample>), SessionError> {
    let mut rec = Recording { t_s: Some(vec![]), roll_deg: Some(vec![]), pitch_deg: Some(vec![]), ref_heading_deg: Some(vec![]), lat_deg: Some(vec![]), lon_deg: Some(vec![]), ..Recording::default() };
    let mut samples = Vec::new();
    let timeout = Duration::from_millis(3000);
    let mut i = 0;
    let started = Instant::now();
    let mut lost = 0usize;
    while let Some(step) = vehicle.next_step()? {
        let taken = take_sample(link, vehicle, &step, send_attitude, timeout);
        let sample = match (taken, resume.as_mut()) {
            (Ok(s), _) => s,
            (Err(SessionError::Link(e)), Some(r)) if !matches!(e, LinkError::Remote(_)) => {
                eprintln!("  link lost at step {i} ({e}); reconnecting");
                *link = reconnect(r)?;
                lost += 1;
                magcal_protocol::Sample { t_ms: 0, raw: None, field_nt: None, heading_rad: None, saturated: false, feed_seq: None }
            }
            (Err(SessionError::NoSample { .. }), Some(r)) => {
                eprintln!("  no sample at step {i}; reconnecting");
                *link = reconnect(r)?;
                lost += 1;
                magcal_protocol::Sample { t_ms: 0, raw: None, field_nt: None, heading_rad: None, saturated: false, feed_seq: None }
            }
            (Err(e), _) => return Err(e),
        };
        let raw = sample.raw.map(|r| r.map(f64::from)).unwrap_or([f64::NAN; 3]);
        rec.mag.push(raw);
        for (col, v) in [
            (&mut rec.t_s, step.t_s),
            (&mut rec.roll_deg, step.roll_deg),
            (&mut rec.pitch_deg, step.pitch_deg),
            (&mut rec.ref_heading_deg, step.ref_heading_deg),
            (&mut rec.lat_deg, step.lat_deg),
            (&mut rec.lon_deg, step.lon_deg),
        ] {
            if let Some(c) = col.as_mut() {
                c.push(v);
            }
        }
        on_step(i, &step, &sample, link)?;
        samples.push(sample);
        i += 1;
    }
    if i > 0 {
        eprintln!("  {i} steps in {:.1} s ({:.0} ms a step)", started.elapsed().as_secs_f64(), started.elapsed().as_secs_f64() * 1000.0 / i as f64);
    }
    if lost > 0 {
        eprintln!("  {lost} steps lost to link drops are kept as rows without a field");
    }
    Ok((rec, samples))
}

/// One recording phase with its progress display, saved as `<label>.csv` in
/// the session directory.
fn record_phase<P: Read + Write>(
    link: &mut Link<P>,
    vehicle: &mut impl Vehicle,
    send_attitude: bool,
    resume: Option<Resume<'_, P>>,
    label: &str,
    cfg: &SessionConfig,
) -> Result<(Recording, Vec<magcal_protocol::Sample>), SessionError> {
    let mut progress = Progress::new(label, vehicle.len_hint().unwrap_or(0), cfg.interactive);
    let (rec, samples) = record_resuming(link, vehicle, send_attitude, resume, |i, _, _, _| {
        progress.update(i, "recording");
        Ok(())
    })?;
    progress.finish();
    let path = cfg.out_dir.join(format!("{label}.csv"));
    rec.write(&path).map_err(|e| SessionError::Io(e.to_string()))?;
    Ok((rec, samples))
}

/// Sends the attitude (if asked) and waits for the board's sample of a step.
fn take_sample<P: Read + Write>(link: &mut Link<P>, vehicle: &mut impl Vehicle, step: &Step, send_attitude: bool, timeout: Duration) -> Result<magcal_protocol::Sample, SessionError> {
    if send_attitude {
        link.attitude(step.roll_deg.to_radians() as f32, step.pitch_deg.to_radians() as f32)?;
    }
    let deadline = Instant::now() + timeout;
    let mut repeat_at = Instant::now() + Duration::from_millis(300);
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        if left.is_zero() {
            return Err(SessionError::NoSample { step: 0, timeout_ms: timeout.as_millis() as u64 });
        }
        match link.next_sample(left.min(Duration::from_millis(100)))? {
            Some(s) if step.feed_seq.is_none() || s.feed_seq == step.feed_seq => return Ok(s),
            _ => {}
        }
        if Instant::now() >= repeat_at {
            vehicle.repeat()?;
            repeat_at = Instant::now() + Duration::from_millis(300);
        }
    }
}

/// Opens the link again and restarts the stream.
fn reconnect<P: Read + Write>(r: &mut Resume<'_, P>) -> Result<Link<P>, SessionError> {
    let mut last = None;
    for _ in 0..r.attempts.max(1) {
        match (r.connect)() {
            Ok(mut l) => match l.set_stream(r.stream).and_then(|()| l.set_output_rate(100)) {
                Ok(()) => return Ok(l),
                Err(e) => last = Some(e),
            },
            Err(e) => last = Some(e),
        }
        std::thread::sleep(Duration::from_millis(200));
    }
    Err(last.map_or(SessionError::NotVerified(r.attempts), SessionError::Link))
}

/// Converts a calibration document to the board's coefficients.
pub fn to_coefficients(doc: &CalDoc) -> Coefficients {
    let s = doc.swing.map(|s| [s.a, s.b, s.c, s.d, s.e]).unwrap_or([0.0; 5]);
    Coefficients {
        bias: doc.bias.map(|v| v as f32),
        matrix: doc.matrix.map(|r| r.map(|v| v as f32)),
        swing: s.map(|v| v as f32),
        declination_rad: doc.declination_deg.unwrap_or(0.0).to_radians() as f32,
        field_nt: doc.field_nt as f32,
    }
}

/// Uploads and verifies, reconnecting and resuming when the link fails.
/// After a failure the board's coefficients are read back first: if the set
/// already landed (the reply was lost), it is verified, not written twice.
pub fn upload_verified<P: Read + Write>(
    mut connect: impl FnMut() -> Result<Link<P>, LinkError>,
    c: &Coefficients,
    attempts: u32,
) -> Result<u32, SessionError> {
    for attempt in 1..=attempts {
        let mut link = match connect() {
            Ok(l) => l,
            Err(e) => {
                eprintln!("  upload attempt {attempt}: cannot connect ({e}); retrying");
                continue;
            }
        };
        if let Ok((back, magcal_protocol::CoefficientSource::Stored, seq)) = link.read_coefficients() {
            if back == *c {
                return Ok(seq);
            }
        }
        match link.upload_coefficients(c) {
            Ok(seq) => return Ok(seq),
            Err(LinkError::Remote(e)) => return Err(LinkError::Remote(e).into()),
            Err(e) => eprintln!("  upload attempt {attempt} failed ({e}); reconnecting"),
        }
    }
    Err(SessionError::NotVerified(attempts))
}

/// The site and options of a session.
#[derive(Debug, Clone)]
pub struct SessionConfig {
    /// Latitude, degrees.
    pub lat_deg: f64,
    /// Longitude, degrees.
    pub lon_deg: f64,
    /// Decimal year.
    pub year: f64,
    /// Output directory.
    pub out_dir: PathBuf,
    /// Show progress bars (a terminal); otherwise plain progress lines.
    pub interactive: bool,
}

/// Progress display: indicatif bars on a terminal, plain lines otherwise.
pub struct Progress {
    bar: Option<indicatif::ProgressBar>,
    label: String,
    total: usize,
    last_line: Instant,
}

impl Progress {
    /// A progress display for `total` steps.
    pub fn new(label: &str, total: usize, interactive: bool) -> Self {
        let bar = interactive.then(|| {
            // A stream of unknown length (a real vehicle) gets a spinner.
            let b = if total == 0 { indicatif::ProgressBar::new_spinner() } else { indicatif::ProgressBar::new(total as u64) };
            if let Ok(style) = indicatif::ProgressStyle::with_template("{msg:>14} [{bar:40}] {pos}/{len} {wide_msg}") {
                b.set_style(style);
            }
            b.set_message(label.to_string());
            b
        });
        Self { bar, label: label.to_string(), total, last_line: Instant::now() - Duration::from_secs(10) }
    }

    /// Step `i` done; `detail` is the current guidance or state.
    pub fn update(&mut self, i: usize, detail: &str) {
        match &self.bar {
            Some(b) => {
                b.set_position(i as u64 + 1);
                b.set_message(format!("{} {detail}", self.label));
            }
            None => {
                if self.last_line.elapsed() > Duration::from_secs(2) || i + 1 == self.total {
                    eprintln!("  {} {}/{}: {detail}", self.label, i + 1, self.total);
                    self.last_line = Instant::now();
                }
            }
        }
    }

    /// Done.
    pub fn finish(&self) {
        if let Some(b) = &self.bar {
            b.finish();
        }
    }
}

/// Results of the computation phase.
pub struct Calibrations {
    /// Step 1: axis fit of the swing test.
    pub step1: CalDoc,
    /// After our back-stepping.
    pub backstepped: CalDoc,
    /// After the swing fit: what goes to the board.
    pub final_doc: CalDoc,
}

/// The host computation on the two recordings (saved beside them).
pub fn compute(swing: &Recording, run: &Recording, cfg: &SessionConfig) -> Result<Calibrations, SessionError> {
    let field = crate::igrf::igrf14(cfg.lat_deg, cfg.lon_deg, 0.0, cfg.year).map_err(|e| SessionError::Io(e.to_string()))?;
    let mut step1 = pipeline::fit_recording(swing, &FitOptions { model: ModelKind::Axis, field_nt: field.total_nt(), saturation: None, allow_weak: false })?;
    step1.declination_deg = Some(field.declination_deg());
    let mut opts = BackstepOptions::new(RunReference::Igrf { lat_deg: cfg.lat_deg, lon_deg: cfg.lon_deg, year: cfg.year });
    opts.swing = Some((swing.complete_mag().1, field.total_nt()));
    let (backstepped, _) = pipeline::backstep_recording(run, &step1, &opts)?;
    let (final_doc, _, _) = pipeline::swing_recording(run, &backstepped, Delay::Estimate { max_s: 5.0 })?;
    Ok(Calibrations { step1, backstepped, final_doc })
}

/// Writes a file in the session directory.
pub fn save_text(dir: &Path, name: &str, text: &str) -> Result<PathBuf, SessionError> {
    let p = dir.join(name);
    std::fs::write(&p, text).map_err(|e| SessionError::Io(format!("{}: {e}", p.display())))?;
    Ok(p)
}

/// Heading and field errors of the board's own output on a validation run
/// against the simulator's truth, plus what the default (uncalibrated)
/// coefficients would have given.
pub fn validation_metrics(sim: &Simulation, rec: &Recording, samples: &[magcal_protocol::Sample], before: &CalDoc) -> serde_json::Value {
    let cal_before = before.calibration();
    let (roll, pitch) = (rec.roll_deg.as_deref().unwrap_or(&[]), rec.pitch_deg.as_deref().unwrap_or(&[]));
    let (mut sb, mut sa, mut n, mut sf, mut nf) = (0.0, 0.0, 0usize, 0.0, 0usize);
    for (i, s) in samples.iter().enumerate() {
        let truth = sim.true_heading_deg.get(i).copied().unwrap_or(f64::NAN).to_radians();
        if let (Some(h), Some(raw)) = (s.heading_rad, s.raw) {
            let eb = wrap_pi(cal_before.apply(raw.map(f64::from), roll[i].to_radians(), pitch[i].to_radians()).true_heading_rad - truth);
            let ea = wrap_pi(f64::from(h) - truth);
            sb += eb * eb;
            sa += ea * ea;
            n += 1;
        }
        if let (Some(f), Some(lat), Some(lon)) = (s.field_nt, rec.lat_deg.as_ref().and_then(|c| c.get(i)), rec.lon_deg.as_ref().and_then(|c| c.get(i))) {
            if let Ok(r) = crate::igrf::igrf14(*lat, *lon, 0.0, sim.truth.site.year) {
                let m = f.iter().map(|v| f64::from(*v).powi(2)).sum::<f64>().sqrt();
                sf += (m - r.total_nt()).powi(2);
                nf += 1;
            }
        }
    }
    let rms = |s: f64, n: usize| if n == 0 { f64::NAN } else { (s / n as f64).sqrt() };
    json!({
        "heading_rms_deg_before": rms(sb, n).to_degrees(),
        "heading_rms_deg_after": rms(sa, n).to_degrees(),
        "field_error_nt_after": rms(sf, nf),
        "validation_samples": n,
    })
}

/// Starts the on-board fit for the swing test and returns a per-step hook
/// that tracks coverage, polls the fit and shows progress.
pub fn swing_hook<'a, P: Read + Write>(
    progress: &'a mut Progress,
    coverage: &'a mut SwingCoverage,
    step1_guess: &CalDoc,
) -> impl FnMut(usize, &Step, &magcal_protocol::Sample, &mut Link<P>) -> Result<(), SessionError> + 'a {
    let cal = step1_guess.field_cal();
    move |i, step, sample, link| {
        if let Some(raw) = sample.raw {
            let h = cal.apply(raw.map(f64::from));
            let psi = calib_core::heading::magnetic_heading_rad(h, step.roll_deg.to_radians(), step.pitch_deg.to_radians()).to_degrees();
            coverage.add(step.roll_deg, step.pitch_deg, psi);
        }
        if i % 25 == 24 {
            coverage.fit = Some(link.fit_query()?);
        }
        let g = coverage.guidance();
        let fit = coverage.fit.map(|f| format!("on-board fit: {} samples, {}% of directions, {:.0} nT RMS", f.samples, f.coverage_pct, f.residual_rms_nt)).unwrap_or_default();
        progress.update(i, &if g.is_empty() { format!("coverage complete; {fit}") } else { format!("{}; {fit}", g.join("; ")) });
        Ok(())
    }
}

/// Starts the board's streaming for a recording phase; with `fit`, also the
/// on-board fit of the paper's axis model (what the swing test determines).
pub fn prepare_board<P: Read + Write>(link: &mut Link<P>, stream: StreamMode, fit: Option<f32>) -> Result<(), SessionError> {
    link.set_output_rate(100)?;
    link.set_stream(stream)?;
    if let Some(f) = fit {
        link.fit_start(FitModel::Axis, f)?;
    }
    link.clear_samples();
    Ok(())
}

/// How long the simulated field tests are (the demo drives them through the
/// QEMU board in lock-step, one feed frame per sample).
#[derive(Debug, Clone, Copy)]
pub struct SimPlan {
    /// Swing-test sample rate, Hz.
    pub swing_rate_hz: f64,
    /// Calibration run: leg length, m.
    pub run_leg_m: f64,
    /// Calibration run: sample rate, Hz.
    pub run_rate_hz: f64,
    /// Validation run: leg length, m.
    pub validation_leg_m: f64,
    /// Validation run: sample rate, Hz.
    pub validation_rate_hz: f64,
    /// Dolphin profile: time submerged and at the surface, s.
    pub dolphin_s: (f64, f64),
    /// Seed.
    pub seed: u64,
}

impl SimPlan {
    /// `cargo xtask demo`: the paper's swing test, 3 km legs.
    pub fn demo() -> Self {
        Self { swing_rate_hz: 0.5, run_leg_m: 3000.0, run_rate_hz: 0.5, validation_leg_m: 1500.0, validation_rate_hz: 0.5, dolphin_s: (1000.0, 50.0), seed: 7 }
    }

    /// The test suite's shortened scenario.
    pub fn short() -> Self {
        Self { swing_rate_hz: 0.25, run_leg_m: 1500.0, run_rate_hz: 0.5, validation_leg_m: 750.0, validation_rate_hz: 0.25, dolphin_s: (300.0, 40.0), seed: 7 }
    }
}

/// The whole session against a QEMU board whose bridges the simulator plays:
/// swing test, out-and-back run, computation, verified upload, and a
/// validation run on which the board's own headings are compared with the
/// simulator's truth. Writes everything into `cfg.out_dir`; returns the
/// summary.
pub fn run_simulated_session(link_port: &str, feed_port: &str, cfg: &SessionConfig, plan: &SimPlan) -> Result<serde_json::Value, SessionError> {
    use crate::sim::{self, RunParams, SensorModel, Site};
    let io = |e: &dyn std::fmt::Display| SessionError::Io(e.to_string());
    std::fs::create_dir_all(&cfg.out_dir).map_err(|e| io(&e))?;
    let sensor = SensorModel::board_like();
    let site = Site { lat_deg: cfg.lat_deg, lon_deg: cfg.lon_deg, year: cfg.year };
    let field = crate::igrf::igrf14(cfg.lat_deg, cfg.lon_deg, 0.0, cfg.year).map_err(|e| io(&e))?;
    let swing_sim = sim::swing(&sensor, &site, plan.seed, plan.swing_rate_hz).map_err(|e| io(&e))?;
    let (submerged_s, surface_s) = plan.dolphin_s;
    let run_sim = sim::run(&sensor, &site, &RunParams { leg_m: plan.run_leg_m, submerged_s, surface_s, ..RunParams::paper_like() }, plan.seed + 1, plan.run_rate_hz, "run").map_err(|e| io(&e))?;
    let val_sim = sim::run(&sensor, &site, &RunParams { leg_m: plan.validation_leg_m, submerged_s, surface_s, ..RunParams::validation() }, plan.seed + 2, plan.validation_rate_hz, "validation").map_err(|e| io(&e))?;

    let mut link = Link::open(link_port)?;
    let id = link.identify()?;
    eprintln!("session: {} {} on {:?}; IGRF-14 here: F {:.0} nT, I {:.1}°, D {:.2}°", id.name, id.firmware_version, id.platform, field.total_nt(), field.inclination_deg(), field.declination_deg());
    let mut feed = FeedWriter::open(feed_port)?;
    let (board_coefficients, _, _) = link.read_coefficients()?;
    let default_doc = doc_from_coefficients(&board_coefficients);

    // 1. Swing test.
    eprintln!("1/5 swing test: turn the vehicle through every heading, roll ±55°, pitch ±10° (thrusters off)");
    prepare_board(&mut link, StreamMode::Raw, Some(field.total_nt() as f32))?;
    let mut coverage = SwingCoverage::default();
    let mut progress = Progress::new("swing test", swing_sim.recording.len(), cfg.interactive);
    let (swing_rec, _) = {
        let mut vehicle = SimVehicle::new(&swing_sim, &mut feed);
        let hook = swing_hook(&mut progress, &mut coverage, &default_doc);
        record(&mut link, &mut vehicle, false, hook)?
    };
    progress.finish();
    let fit = link.fit_stop()?;
    let guidance = coverage.guidance();
    if !guidance.is_empty() {
        return Err(SessionError::Coverage(guidance.join("; ")));
    }
    eprintln!("  swing test complete: {} headings sectors, on-board fit {} samples, {}% of directions, {:.0} nT RMS", coverage.sectors_visited(), fit.samples, fit.coverage_pct, fit.residual_rms_nt);
    swing_rec.write(&cfg.out_dir.join("swing.csv")).map_err(|e| io(&e))?;

    // 2. Out-and-back run.
    eprintln!("2/5 out-and-back run: {:.0} m legs at 62° / −117°, dolphin profile, GPS at the surface", plan.run_leg_m);
    prepare_board(&mut link, StreamMode::Raw, None)?;
    let (run_rec, _) = record_phase(&mut link, &mut SimVehicle::new(&run_sim, &mut feed), false, None, "run", cfg)?;

    let (cals, seq) = calibrate_and_upload(link, link_port, cfg, &swing_rec, &run_rec)?;
    let bs = &cals.backstepped.quality["backstep"];

    // 5. Validation run with the board's own output.
    eprintln!("5/5 validation run on other courses, headings from the board");
    let mut link = Link::open(link_port)?;
    prepare_board(&mut link, StreamMode::Both, None)?;
    let (val_rec, val_samples) = record_phase(&mut link, &mut SimVehicle::new(&val_sim, &mut feed), true, None, "validation", cfg)?;
    let metrics = validation_metrics(&val_sim, &val_rec, &val_samples, &default_doc);
    link.set_stream(StreamMode::Off)?;

    let cals_for_report: Vec<(String, &CalDoc)> = vec![("step1 (axis fit)".into(), &cals.step1), ("back-stepped".into(), &cals.backstepped), ("final".into(), &cals.final_doc)];
    let inputs = crate::report::ReportInputs { run: Some(&run_rec), swing: Some(&swing_rec), cals: cals_for_report, field_nt: Some(field.total_nt()) };
    crate::report::write_report(&cfg.out_dir.join("report"), &inputs).map_err(|e| io(&e))?;
    let settings = json!({
        "lat_deg": cfg.lat_deg, "lon_deg": cfg.lon_deg, "decimal_year": cfg.year,
        "plan": {"swing_rate_hz": plan.swing_rate_hz, "run_leg_m": plan.run_leg_m, "run_rate_hz": plan.run_rate_hz, "validation_leg_m": plan.validation_leg_m, "validation_rate_hz": plan.validation_rate_hz, "dolphin_s": [plan.dolphin_s.0, plan.dolphin_s.1], "seed": plan.seed},
        "firmware": id.firmware_version.as_str(),
        "reproduce": [
            "magcal fit --input swing.csv --model axis --lat LAT --lon LON --date YEAR --out cal_step1.json",
            "magcal backstep --input run.csv --cal cal_step1.json --swing-input swing.csv --lat LAT --lon LON --date YEAR --out cal_backstep.json",
            "magcal swing --input run.csv --cal cal_backstep.json --estimate-delay --out cal_final.json"
        ],
    });
    save_text(&cfg.out_dir, "settings.json", &serde_json::to_string_pretty(&settings).unwrap_or_default())?;
    let mut summary = metrics;
    summary["coefficients_verified"] = json!(true);
    summary["coefficient_seq"] = json!(seq);
    summary["onboard_fit"] = json!({"samples": fit.samples, "coverage_pct": fit.coverage_pct, "residual_rms_nt": fit.residual_rms_nt});
    summary["backstep"] = bs.clone();
    summary["swing"] = cals.final_doc.quality["swing"].clone();
    summary["session_dir"] = json!(cfg.out_dir);
    save_text(&cfg.out_dir, "summary.json", &serde_json::to_string_pretty(&summary).unwrap_or_default())?;
    Ok(summary)
}

/// Steps 3–4 of every session: computation on the host (saved beside the
/// recordings), then the verified upload (the link is closed and reopened,
/// resuming if it drops).
pub fn calibrate_and_upload(link: Link<Box<dyn serialport::SerialPort>>, link_port: &str, cfg: &SessionConfig, swing_rec: &Recording, run_rec: &Recording) -> Result<(Calibrations, u32), SessionError> {
    let io = |e: &dyn std::fmt::Display| SessionError::Io(e.to_string());
    eprintln!("3/5 computing: axis fit against IGRF, back-stepping, swing fit against the GPS course");
    let cals = compute(swing_rec, run_rec, cfg)?;
    for (name, doc) in [("cal_step1.json", &cals.step1), ("cal_backstep.json", &cals.backstepped), ("cal_final.json", &cals.final_doc)] {
        doc.save(&cfg.out_dir.join(name)).map_err(|e| io(&e))?;
    }
    let bs = &cals.backstepped.quality["backstep"];
    eprintln!("  turnaround step {:.1} → {:.1} nT; |F| − IGRF {:.1} → {:.1} nT RMS", bs["before"]["step_nt"].as_f64().unwrap_or(f64::NAN), bs["after"]["step_nt"].as_f64().unwrap_or(f64::NAN), bs["before"]["f_error_rms_nt"].as_f64().unwrap_or(f64::NAN), bs["after"]["f_error_rms_nt"].as_f64().unwrap_or(f64::NAN));
    eprintln!("4/5 uploading: unlock, stage, commit, read back");
    drop(link);
    let coefficients = to_coefficients(&cals.final_doc);
    let seq = upload_verified(|| Link::open(link_port), &coefficients, 3)?;
    eprintln!("  coefficients #{seq} stored and verified");
    Ok((cals, seq))
}

/// A session with a real vehicle: its navigation for the swing test and the
/// out-and-back run arrives as CSV streams (files, FIFOs); the board streams
/// raw samples; the link is reopened if it drops. No truth, so the summary
/// reports what the data say (residuals, step, GPS fit).
pub fn run_nav_session(link_port: &str, nav_swing: impl std::io::BufRead, nav_run: impl std::io::BufRead, cfg: &SessionConfig) -> Result<serde_json::Value, SessionError> {
    let io = |e: &dyn std::fmt::Display| SessionError::Io(e.to_string());
    std::fs::create_dir_all(&cfg.out_dir).map_err(|e| io(&e))?;
    let field = crate::igrf::igrf14(cfg.lat_deg, cfg.lon_deg, 0.0, cfg.year).map_err(|e| io(&e))?;
    let mut link = Link::open(link_port)?;
    let id = link.identify()?;
    eprintln!("session: {} {} on {:?}; IGRF-14 here: F {:.0} nT", id.name, id.firmware_version, id.platform, field.total_nt());
    let (board_coefficients, _, _) = link.read_coefficients()?;
    let default_doc = doc_from_coefficients(&board_coefficients);
    let mut connect = || Link::open(link_port);

    eprintln!("1/5 swing test: turn the vehicle through every heading, roll ±55°, pitch ±10° (thrusters off)");
    prepare_board(&mut link, StreamMode::Raw, Some(field.total_nt() as f32))?;
    let mut coverage = SwingCoverage::default();
    let mut progress = Progress::new("swing test", 0, cfg.interactive);
    let (swing_rec, _) = {
        let mut vehicle = NavVehicle::new(nav_swing)?;
        let hook = swing_hook(&mut progress, &mut coverage, &default_doc);
        record_resuming(&mut link, &mut vehicle, true, Some(Resume { connect: &mut connect, stream: StreamMode::Raw, attempts: 5 }), hook)?
    };
    progress.finish();
    let fit = link.fit_stop()?;
    let guidance = coverage.guidance();
    if !guidance.is_empty() {
        return Err(SessionError::Coverage(guidance.join("; ")));
    }
    swing_rec.write(&cfg.out_dir.join("swing.csv")).map_err(|e| io(&e))?;

    eprintln!("2/5 out-and-back run");
    prepare_board(&mut link, StreamMode::Raw, None)?;
    let resume = Resume { connect: &mut connect, stream: StreamMode::Raw, attempts: 5 };
    let (run_rec, _) = record_phase(&mut link, &mut NavVehicle::new(nav_run)?, true, Some(resume), "run", cfg)?;

    let (cals, seq) = calibrate_and_upload(link, link_port, cfg, &swing_rec, &run_rec)?;
    let summary = json!({
        "coefficients_verified": true,
        "coefficient_seq": seq,
        "onboard_fit": {"samples": fit.samples, "coverage_pct": fit.coverage_pct, "residual_rms_nt": fit.residual_rms_nt},
        "backstep": cals.backstepped.quality["backstep"].clone(),
        "swing": cals.final_doc.quality["swing"].clone(),
        "session_dir": cfg.out_dir,
    });
    save_text(&cfg.out_dir, "summary.json", &serde_json::to_string_pretty(&summary).unwrap_or_default())?;
    Ok(summary)
}

/// A calibration document for coefficients read from the board.
pub fn doc_from_coefficients(c: &Coefficients) -> CalDoc {
    let field = calib_core::cal::FieldCal { bias: c.bias.map(f64::from), matrix: c.matrix.map(|r| r.map(f64::from)) };
    let mut doc = CalDoc::new(ModelKind::Full, &field, f64::from(c.field_nt), json!({}));
    doc.declination_deg = Some(f64::from(c.declination_rad).to_degrees());
    doc
}

#[cfg(test)]
mod tests;
