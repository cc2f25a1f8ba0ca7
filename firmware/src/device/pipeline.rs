//! The sample pipeline, in one place: a decimated raw sample → the current
//! and temperature terms (with the rules for stale or missing inputs, see
//! the [`super`] module doc) → the on-board fit → the coefficients and the
//! heading → the sample to stream, as the stream mode asks; and the
//! output settings (`SetStream`, `SetOutputRate`). It owns its state
//! ([`Pipeline`]) and is handed the calibration, the inputs and the fit:
//! it knows nothing of [`super::Device`].

use calib_core::cal::{Calibration, Environment};
use magcal_protocol::{DeviceError, RequestBody, Sample, StreamMode};

use super::health::DeviceCounters;
use super::inputs::Inputs;
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
}

impl Pipeline {
    /// Nothing streamed, 10 Hz.
    pub(super) fn new() -> Self {
        Self { stream: StreamMode::Off, output_rate_hz: 10, last_temp_c: None, env_degraded: false, counters: DeviceCounters::default() }
    }
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
    pub(super) fn set_output(&mut self, req: &RequestBody) -> Result<(), DeviceError> {
        match *req {
            RequestBody::SetStream(mode) => self.stream = mode,
            RequestBody::SetOutputRate { hz } if (1..=100).contains(&hz) => self.output_rate_hz = hz,
            RequestBody::SetOutputRate { .. } => return Err(DeviceError::BadArgument),
            _ => return Err(DeviceError::Unsupported),
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
        // The document's formula, as calib-core applies it (~260
        // instructions a sample with the heading: `cargo xtask bench`).
        // (`apply_tilt_env` is `correct_raw` then `apply_tilt`: the corrected
        // sample is kept for the fit.)
        let corrected = cal.env.correct_raw(raw.field_counts, &env);
        let (field, heading_rad) = match inputs.tilt(now_ms) {
            Some(tilt) => {
                let out = cal.apply_tilt(corrected, &tilt);
                (out.field_nt, current_ok.then_some(out.true_heading_rad))
            }
            None => (cal.field.apply(corrected), None),
        };
        if let Some(f) = fit {
            if f.running() && !raw.saturated {
                // The fit estimates the field calibration of the corrected
                // sample (the terms stay as stored).
                f.push(corrected, inputs.motion(), now_ms);
            }
        }
        let (raw_out, cal_out) = match self.stream {
            StreamMode::Off => return None,
            StreamMode::Raw => (Some(raw.field_counts), None),
            StreamMode::Calibrated => (None, Some(field)),
            StreamMode::Both => (Some(raw.field_counts), Some(field)),
        };
        Some(Sample {
            t_ms: now_ms,
            raw: raw_out,
            field_nt: cal_out,
            heading_rad: heading_rad.filter(|_| cal_out.is_some()),
            saturated: raw.saturated,
            feed_seq: raw.tag,
            temp_c: raw.temp_c,
        })
    }
}
