//! Recording a manoeuvre: per step, the vehicle's stimulus or navigation,
//! the attitude to the board when wanted, and the board's sample for that
//! step; the link reopened when it drops, the lost steps kept as rows
//! without a field (never invented).

use std::io::{Read, Write};
use std::time::{Duration, Instant};

use magcal_protocol::Sample;

use super::vehicle::{Taken, Step, Vehicle, STEP_COLUMNS};
use super::error::SessionError;
use crate::board::reconnect::{reconnect_at, Resume};
use crate::board::{BoardClient, ClientError};
use crate::data::pairing::{ClockMap, TimePairer};
use crate::data::table::ColumnSet;
use crate::data::Recording;

/// A recorded manoeuvre.
#[derive(Debug, Clone)]
pub struct Recorded {
    /// The recording in the INTERFACES.md columns; roll and pitch are the AHRS's.
    pub recording: Recording,
    /// The board's sample of every step (`raw: None` for a lost one).
    pub samples: Vec<Sample>,
    /// The vehicle's true heading at every step, degrees (NaN when unknown).
    pub true_heading_deg: Vec<f64>,
    /// The magnitude of the true local field at every step, nT (NaN when
    /// unknown).
    pub true_field_nt: Vec<f64>,
    /// Steps lost to link drops.
    pub lost_steps: usize,
}

/// How long the board has to deliver a step's sample.
const SAMPLE_TIMEOUT: Duration = Duration::from_millis(3000);

fn lost_sample() -> Sample {
    Sample { t_ms: 0, raw: None, field_nt: None, heading_rad: None, saturated: false, feed_seq: None, temp_c: None, heading_sigma_deg: None, integrity: magcal_protocol::Integrity::NoAttitude }
}

/// Records the current manoeuvre of `vehicle`. `on_step` sees every step
/// with its sample (coverage, progress). With `resume`, a dropped link is
/// reopened and recording goes on.
pub fn record<P: Read + Write>(
    link: &mut BoardClient<P>,
    vehicle: &mut dyn Vehicle,
    send_attitude: bool,
    mut resume: Option<Resume<'_, P>>,
    mut on_step: impl FnMut(usize, &Step, &Sample, &mut BoardClient<P>) -> Result<(), SessionError>,
) -> Result<Recorded, SessionError> {
    let mut rec = Recording::default();
    for c in STEP_COLUMNS.iter().filter(|c| c.recorded == Taken::FromStart) {
        if let Some(slot) = rec.column_slot(c.name) {
            *slot = Some(vec![]);
        }
    }
    let (mut samples, mut truth, mut truth_field) = (Vec::new(), Vec::new(), Vec::new());
    let mut i = 0;
    let started = Instant::now();
    let mut lost = 0usize;
    let mut pairing = Pairing::default();
    while let Some(step) = vehicle.next_step()? {
        let taken = take_sample(link, vehicle, &step, send_attitude, SAMPLE_TIMEOUT, &mut pairing);
        let sample = match (taken, resume.as_mut()) {
            (Ok(s), _) => s,
            (Err(SessionError::Link(e)), Some(r)) if !matches!(e, ClientError::Remote(_)) => {
                eprintln!("  link lost at step {i} ({e}); reconnecting");
                *link = reconnect(r)?;
                lost += 1;
                lost_sample()
            }
            (Err(SessionError::NoSample { .. }), Some(r)) => {
                eprintln!("  no sample at step {i}; reconnecting");
                *link = reconnect(r)?;
                lost += 1;
                lost_sample()
            }
            (Err(SessionError::NoSample { timeout_ms, .. }), None) => return Err(SessionError::NoSample { step: i, timeout_ms }),
            (Err(e), _) => return Err(e),
        };
        let raw = sample.raw.map(|r| r.map(f64::from)).unwrap_or([f64::NAN; 3]);
        rec.mag.push(raw);
        // The step's columns the recording holds, by registry name.
        let rows = rec.mag.len() - 1;
        for c in &STEP_COLUMNS {
            let take = match c.recorded {
                Taken::FromStart => true,
                Taken::OnceAny(names) => names.iter().any(|n| step.column(n).is_some_and(f64::is_finite)),
                Taken::Never => continue,
            };
            if let Some(slot) = rec.column_slot(c.name) {
                if take || slot.is_some() {
                    slot.get_or_insert_with(|| vec![f64::NAN; rows]).push((c.get)(&step));
                }
            }
        }
        // The board's measured temperature once a sample has it (earlier rows NaN).
        if sample.temp_c.is_some() || rec.temp_c.is_some() {
            rec.temp_c.get_or_insert_with(|| vec![f64::NAN; rows]).push(sample.temp_c.map_or(f64::NAN, f64::from));
        }
        on_step(i, &step, &sample, link)?;
        samples.push(sample);
        truth.push(step.true_heading_deg);
        truth_field.push(step.true_field_nt);
        i += 1;
    }
    if i > 0 {
        eprintln!("  {i} steps in {:.1} s ({:.0} ms a step)", started.elapsed().as_secs_f64(), started.elapsed().as_secs_f64() * 1000.0 / i as f64);
    }
    if lost > 0 {
        eprintln!("  {lost} steps lost to link drops are kept as rows without a field");
    }
    Ok(Recorded { recording: rec, samples, true_heading_deg: truth, true_field_nt: truth_field, lost_steps: lost })
}

/// Pairing a real vehicle's navigation rows with the board's stream by time
/// ([`crate::data::pairing`], shared with `magcal merge`): the clock map
/// is set at the first row (the newest sample then is "now" on both
/// clocks) and each later row takes the sample nearest its time on the
/// board's clock, so the lag stays within half a sample interval (plus the
/// clocks' drift) however much faster the board streams.
#[derive(Default)]
struct Pairing {
    clock: Option<ClockMap>,
    pairer: TimePairer<Sample>,
}

/// Sends the attitude (when wanted) and waits for the board's sample of this
/// step: with a simulated vehicle the one carrying the step's feed sequence
/// number (re-sending the stimulus if it seems lost), otherwise the one
/// nearest the step's time (see [`Pairing`]).
fn take_sample<P: Read + Write>(
    link: &mut BoardClient<P>,
    vehicle: &mut dyn Vehicle,
    step: &Step,
    send_attitude: bool,
    timeout: Duration,
    pairing: &mut Pairing,
) -> Result<Sample, SessionError> {
    if send_attitude {
        let (roll, pitch) = (step.roll_deg.to_radians() as f32, step.pitch_deg.to_radians() as f32);
        let has_rates = step.rate_rad_s.iter().all(|w| w.is_finite());
        if has_rates {
            link.motion(roll, pitch, step.rate_rad_s.map(|w| w as f32))?;
        }
        // The motor current goes with the attitude when the navigation has
        // it (the board's current term needs it fresh for the heading).
        if step.motor_current_a.is_finite() {
            link.attitude_env(roll, pitch, step.motor_current_a as f32)?;
        } else if !has_rates {
            link.attitude(roll, pitch)?;
        }
    }
    let deadline = Instant::now() + timeout;
    if step.feed_seq.is_none() {
        return take_by_time(link, step, deadline, pairing);
    }
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

/// The sample nearest the step's time on the board's clock (the real
/// vehicle's pairing).
fn take_by_time<P: Read + Write>(link: &mut BoardClient<P>, step: &Step, deadline: Instant, pairing: &mut Pairing) -> Result<Sample, SessionError> {
    let no_sample = || SessionError::NoSample { step: 0, timeout_ms: SAMPLE_TIMEOUT.as_millis() as u64 };
    loop {
        match pairing.clock {
            None => {
                // The first row: the newest sample that has arrived is "now"
                // (bounded, for a stream that never pauses).
                for _ in 0..10_000 {
                    match link.next_sample(Duration::ZERO)? {
                        Some(s) => pairing.pairer.push(f64::from(s.t_ms) / 1000.0, s),
                        None => break,
                    }
                }
                if let Some(now_board_s) = pairing.pairer.newest_s() {
                    pairing.clock = Some(ClockMap { offset_s: step.t_s - now_board_s, drift_ppm: 0.0, board_ref_s: now_board_s });
                    return pairing.pairer.take_nearest(now_board_s).map(|(_, s)| s).ok_or_else(no_sample);
                }
            }
            Some(clock) => {
                if let Some((_, s)) = pairing.pairer.take_nearest(clock.to_board(step.t_s)) {
                    return Ok(s);
                }
            }
        }
        let left = deadline.saturating_duration_since(Instant::now());
        if left.is_zero() {
            return Err(no_sample());
        }
        if let Some(s) = link.next_sample(left.min(Duration::from_millis(100)))? {
            pairing.pairer.push(f64::from(s.t_ms) / 1000.0, s);
        }
    }
}

/// Opens the link again and restarts the stream at 100 Hz.
fn reconnect<P: Read + Write>(r: &mut Resume<'_, P>) -> Result<BoardClient<P>, SessionError> {
    Ok(reconnect_at(r, 100)?)
}
