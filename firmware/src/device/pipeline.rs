//! The sample pipeline, in one place: a decimated raw sample → the current
//! and temperature terms (with the rules for stale or missing inputs, see
//! the [`super`] module doc) → the on-board fit → the coefficients and the
//! heading → the sample to stream, as the stream mode asks; and the
//! output settings (`SetStream`, `SetOutputRate`).

use calib_core::cal::Environment;
use magcal_protocol::{DeviceError, RequestBody, ResponseBody, Sample, StreamMode};

use super::health::DeviceCounters;
use super::Device;
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

impl Device {
    /// The output rate asked for, Hz.
    pub fn output_rate_hz(&self) -> u8 {
        self.pipeline.output_rate_hz
    }

    /// What is streamed.
    pub fn stream(&self) -> StreamMode {
        self.pipeline.stream
    }

    /// What the board streams and how often.
    pub(super) fn handle_output(&mut self, req: &RequestBody) -> ResponseBody {
        match *req {
            RequestBody::SetStream(mode) => {
                self.pipeline.stream = mode;
                ResponseBody::Ack
            }
            RequestBody::SetOutputRate { hz } => {
                if !(1..=100).contains(&hz) {
                    return self.refuse(DeviceError::BadArgument);
                }
                self.pipeline.output_rate_hz = hz;
                ResponseBody::Ack
            }
            _ => ResponseBody::Error(DeviceError::Unsupported),
        }
    }

    /// The current and temperature a sample is corrected with, counting
    /// the stale current and the missing temperature.
    fn sample_env(&mut self, temp_c: Option<f32>, now_ms: u32) -> SampleEnv {
        let terms = &self.calibration.env;
        let current_a = self.inputs.current_a(now_ms);
        let current_ok = current_a.is_some() || terms.bias_per_a.iter().all(|b| *b == 0.0);
        let env = Environment { current_a: current_a.unwrap_or(0.0), temp_c: temp_c.unwrap_or(terms.ref_c) };
        let p = &mut self.pipeline;
        match temp_c {
            Some(t) => p.last_temp_c = Some(t),
            None => p.counters.temp_missing = p.counters.temp_missing.wrapping_add(1),
        }
        if !current_ok {
            p.counters.current_stale = p.counters.current_stale.wrapping_add(1);
        }
        p.env_degraded = temp_c.is_none() || !current_ok;
        SampleEnv { env, current_ok }
    }

    /// Processes one decimated raw sample: applies the current and
    /// temperature terms (see the module doc for stale or missing inputs),
    /// feeds the corrected sample to the on-board fit, applies the
    /// coefficients and the heading (with a fresh attitude, and a fresh
    /// current when the current term needs one), and returns the sample to
    /// stream, if streaming.
    pub fn on_raw_sample(&mut self, raw: &RawSample, now_ms: u32) -> Option<Sample> {
        self.pipeline.counters.samples = self.pipeline.counters.samples.wrapping_add(1);
        let SampleEnv { env, current_ok } = self.sample_env(raw.temp_c, now_ms);
        // The document's formula, as calib-core applies it (~260
        // instructions a sample with the heading: `cargo xtask bench`).
        // (`apply_tilt_env` is `correct_raw` then `apply_tilt`: the corrected
        // sample is kept for the fit.)
        let corrected = self.calibration.env.correct_raw(raw.field_counts, &env);
        let (field, heading_rad) = match self.inputs.tilt(now_ms) {
            Some(tilt) => {
                let out = self.calibration.apply_tilt(corrected, &tilt);
                (out.field_nt, current_ok.then_some(out.true_heading_rad))
            }
            None => (self.calibration.field.apply(corrected), None),
        };
        if let Some(f) = &mut self.fit {
            if f.running() && !raw.saturated {
                // The fit estimates the field calibration of the corrected
                // sample (the terms stay as stored).
                f.push(corrected, self.inputs.motion(), now_ms);
            }
        }
        let (raw_out, cal_out) = match self.pipeline.stream {
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
