//! The sample pipeline, in one place: a decimated raw sample → the current
//! and temperature terms (with the rules for stale or missing inputs, see
//! the [`super`] module doc) → the on-board fit → the coefficients and the
//! heading → the sample to stream, as the stream mode asks; and the
//! output settings (`SetStream`, `SetOutputRate`). It owns its state
//! ([`Pipeline`]) and is handed the calibration, the inputs and the fit:
//! it knows nothing of [`super::Device`].
//!
//! Every output sample is judged by calib-core's [`OnlineIntegrity`] (f32,
//! the same code as `magcal apply` on the host, and the same bits for a
//! document that gives only `field_nt`; a host document's fit residual,
//! inclination and predicted error, which the board does not store, make
//! `apply`'s gates and σ its own): the heading's 1σ and the
//! integrity state go out with the sample, the on-line hard iron is
//! applied under its guard, and the counters feed `Health`. The reference
//! is the stored set's `field_nt` and reference inclination ([`OnlineIntegrity::for_stored`]);
//! a new set starts a new judgement ([`Pipeline::restart_integrity`]).

use calib_core::cal::{Calibration, Environment};
use calib_core::integrity::{decide, Evidence};
use calib_core::online::OnlineIntegrity;
use magcal_protocol::{DeviceError, Integrity, Sample, StreamMode};

use super::OutputRequest;

use magcal_protocol::DeviceCounters;
use super::inputs::{fresh, Inputs};
use super::onboard_fit::OnboardFit;
use crate::acquisition::RawSample;

/// What the pipeline keeps between samples.
#[derive(Debug, Clone, Copy)]
pub(super) struct Pipeline {
    pub(super) stream: StreamMode,
    pub(super) output_rate_hz: u8,
    /// The last valid temperature, °C.
    pub(super) last_temp_c: Option<f32>,
    /// The last sample used a stale current or a missing temperature.
    pub(super) env_degraded: bool,
    pub(super) counters: DeviceCounters,
    /// The heading's integrity for the calibration in use (`None` if its
    /// `field_nt` cannot be a reference — never for a validated set).
    pub(super) integrity: Option<OnlineIntegrity<f32>>,
    /// Board time of the previous output sample, ms.
    last_ms: Option<u32>,
}

impl Pipeline {
    /// Nothing streamed, 10 Hz; the integrity judged against `field_nt`
    /// and the stored reference inclination (learned when `None`).
    pub(super) fn new(field_nt: f32, inclination_rad: Option<f32>) -> Self {
        Self {
            stream: StreamMode::Off,
            output_rate_hz: 10,
            last_temp_c: None,
            env_degraded: false,
            counters: DeviceCounters::default(),
            integrity: OnlineIntegrity::for_stored(field_nt, inclination_rad).ok(),
            last_ms: None,
        }
    }

    /// A new calibration (of intensity `field_nt`) is in use: its integrity
    /// starts afresh (the old one's counters, learned inclination and
    /// hard-iron estimate belonged to the old set).
    pub(super) fn restart_integrity(&mut self, field_nt: f32, inclination_rad: Option<f32>) {
        self.integrity = OnlineIntegrity::for_stored(field_nt, inclination_rad).ok();
    }
}

/// A sample calibrated and judged.
struct Judged {
    field_nt: [f32; 3],
    heading_rad: Option<f32>,
    heading_sigma_deg: Option<f32>,
    integrity: Integrity,
}

/// The environment a sample is corrected for, and whether its current
/// is good enough for the heading.
struct SampleEnv {
    env: Environment<f32>,
    current_ok: bool,
}

impl Pipeline {
    /// Takes a `SetStream` or `SetOutputRate` request (rate 1–100 Hz, else
    /// [`DeviceError::BadArgument`]).
    pub(super) fn set_output(&mut self, req: OutputRequest) -> Result<(), DeviceError> {
        match req {
            OutputRequest::Stream(mode) => self.stream = mode,
            OutputRequest::Rate(hz) if (1..=100).contains(&hz) => self.output_rate_hz = hz,
            OutputRequest::Rate(_) => return Err(DeviceError::BadArgument),
        }
        Ok(())
    }

    /// The current and temperature a sample is corrected with, counting
    /// the stale current and the missing temperature.
    fn sample_env(&mut self, cal: &Calibration<f32>, inputs: &Inputs, temp_c: Option<f32>, now_ms: u32) -> SampleEnv {
        let terms = &cal.env;
        let current_a = inputs.current_a(now_ms);
        let current_ok = current_a.is_some() || terms.bias_per_a.iter().all(|b| *b == 0.0);
        let env = Environment { current_a: current_a.unwrap_or(0.0), temp_c: temp_c.unwrap_or(terms.ref_c) };
        match temp_c {
            Some(t) => self.last_temp_c = Some(t),
            None => self.counters.temp_missing = self.counters.temp_missing.wrapping_add(1),
        }
        if !current_ok {
            self.counters.current_stale = self.counters.current_stale.wrapping_add(1);
        }
        self.env_degraded = temp_c.is_none() || !current_ok;
        SampleEnv { env, current_ok }
    }

    /// Processes one decimated raw sample with the calibration `cal` and the
    /// vehicle's `inputs`: applies the current and temperature terms (see
    /// the [`super`] module doc for stale or missing inputs), feeds the
    /// corrected sample to the on-board `fit`, applies the coefficients and
    /// the heading (with a fresh attitude, and a fresh current when the
    /// current term needs one), and returns the sample to stream, if
    /// streaming.
    pub(super) fn process(&mut self, raw: &RawSample, now_ms: u32, cal: &Calibration<f32>, inputs: &Inputs, fit: Option<&mut OnboardFit>) -> Option<Sample> {
        self.counters.samples = self.counters.samples.wrapping_add(1);
        let SampleEnv { env, current_ok } = self.sample_env(cal, inputs, raw.temp_c, now_ms);
        // The document's formula, as calib-core applies it, then the
        // integrity (`OnlineIntegrity::process` calls `apply_tilt`; the
        // corrected sample is kept for the fit). Cost: `cargo xtask bench`.
        let corrected = cal.env.correct_raw(raw.field_counts, &env);
        // The heading needs a fresh attitude, and a fresh current when the
        // current term needs one; the gyro check a fresh body rate.
        let tilt = inputs.tilt(now_ms).filter(|_| current_ok);
        let rate_rad_s = inputs.motion().filter(|m| fresh(m.at_ms, now_ms)).map(|m| m.rate_rad_s);
        let dt_s = self.last_ms.replace(now_ms).map_or(f32::NAN, |l| now_ms.wrapping_sub(l) as f32 * 1e-3);
        let judged = match self.integrity.as_mut() {
            Some(online) => {
                let j = online.process(cal, corrected, tilt.as_ref(), rate_rad_s, dt_s);
                let sigma_deg = j.heading_rad.map(|_| j.verdict.heading_sigma_rad.to_degrees());
                Judged { field_nt: j.field_nt, heading_rad: j.heading_rad, heading_sigma_deg: sigma_deg, integrity: j.verdict.state }
            }
            // No reference to judge against: the heading cannot be trusted.
            None => {
                let integrity = decide(&Evidence::without_monitor(true, tilt.is_some()));
                match tilt {
                    Some(t) => {
                        let out = cal.apply_tilt(corrected, &t);
                        Judged { field_nt: out.field_nt, heading_rad: Some(out.true_heading_rad), heading_sigma_deg: None, integrity }
                    }
                    None => Judged { field_nt: cal.field.apply(corrected), heading_rad: None, heading_sigma_deg: None, integrity },
                }
            }
        };
        if let Some(f) = fit {
            if f.running() && !raw.saturated {
                // The fit estimates the field calibration of the corrected
                // sample (the terms stay as stored).
                f.push(corrected, inputs.motion(), now_ms);
            }
        }
        let field = judged.field_nt;
        let (raw_out, cal_out) = match self.stream {
            StreamMode::Off => return None,
            StreamMode::Raw => (Some(raw.field_counts), None),
            StreamMode::Calibrated | StreamMode::Nmea => (None, Some(field)),
            StreamMode::Both => (Some(raw.field_counts), Some(field)),
        };
        Some(Sample {
            t_ms: now_ms,
            raw: raw_out,
            field_nt: cal_out,
            heading_rad: judged.heading_rad.filter(|_| cal_out.is_some()),
            saturated: raw.saturated,
            feed_seq: raw.tag,
            temp_c: raw.temp_c,
            heading_sigma_deg: judged.heading_sigma_deg,
            integrity: judged.integrity,
        })
    }
}
