//! The board's behaviour, apart from the hardware: requests in, replies out;
//! raw samples in, calibrated samples out. Host-testable; the RTIC app owns
//! one [`Device`] and calls it from its tasks.
//!
//! One job per room:
//! * [`coefficients`](self::coefficients): the coefficient bank (in use,
//!   staged, sequence, write lock) — validation, the store's encoding
//!   (record versions 1, 2 and 3), read / write / commit;
//! * [`unlock`](self::unlock): the write lock — challenge, expiry, mission
//!   mode;
//! * [`inputs`](self::inputs): what the vehicle sends — attitude, body
//!   rates, motor current — checked once and stale after
//!   [`ATTITUDE_TIMEOUT_MS`];
//! * [`onboard_fit`](self::onboard_fit): the recursive fits (sphere, axis,
//!   full, gyro-aided) behind one estimator interface;
//! * [`pipeline`](self::pipeline): every raw sample to a calibrated sample
//!   (stream mode and output rate included);
//! * [`health`](self::health): the one status snapshot.
//!
//! This root holds the [`Device`] and routes each request (one arm per
//! endpoint of the protocol's table) to its room.
//!
//! Coefficient safety:
//! * every set is validated (finite, orientation-preserving, plausible
//!   anisotropy, bias within the ADC range, swing below 1 rad, declination
//!   within ±π, field 10 000–100 000 nT) before it is staged, stored or used;
//! * writes need an unlock (the boot's challenge XOR [`UNLOCK_XOR`]) that
//!   expires, and are refused in mission mode;
//! * a commit must quote the CRC of what was staged, is stored first and used
//!   only once stored (a failed write keeps the old set in use).
//!
//! Current and temperature terms (the calibration document's `current` and
//! `temperature` blocks) are applied to every sample,
//! `h = M·(raw ⊘ (1 + k ⊙ (T − T₀)) − b − c·I)`
//! ([`calib_core::cal::Calibration::apply_tilt_env`]), with:
//! * the temperature `T` measured on the board (the thermistor on ADC
//!   channel 3, [`crate::thermistor`]); when it is missing (open or shorted
//!   thermistor) the sample is corrected at the reference `T₀` (no gain
//!   correction), `Sample::temp_c` is `None`, `DeviceCounters::temp_missing` counts
//!   it and `Health::env_degraded` is set;
//! * the motor current `I` from [`RequestBody::AttitudeEnv`], stale after
//!   [`ATTITUDE_TIMEOUT_MS`] like the attitude. A stale or never-sent
//!   current counts as 0 A for the field; if the stored current term is
//!   non-zero the sample's heading is withheld (`None`, as for a stale
//!   attitude), `DeviceCounters::current_stale` counts it and `env_degraded` is
//!   set. With a zero current term the current is not needed.

mod coefficients;
mod health;
mod inputs;
mod onboard_fit;
mod pipeline;
mod unlock;

use calib_core::cal::Calibration;
use magcal_protocol::endpoint::{Ack, Pong};
use magcal_protocol::{Call, Coefficients, DeviceError, Endpoint, RequestBody, ResponseBody, Sample, StreamMode};

use crate::acquisition::RawSample;
#[cfg(doc)]
use magcal_protocol::{ATTITUDE_TIMEOUT_MS, UNLOCK_XOR};

pub use coefficients::{
    decode_coefficients, default_coefficients, encode_coefficients, validate, CoefficientStore, PendingCommit, SaveFailed, FIELD_RANGE_NT, MAX_CURRENT_BIAS_PER_A,
};
pub use magcal_protocol::{BoardCounters, DeviceCounters};
pub use unlock::FUZZ_CHALLENGE;

use inputs::Inputs;
use onboard_fit::OnboardFit;
use pipeline::Pipeline;
use coefficients::Bank;

/// What a request needs next.
#[derive(Debug, Clone)]
pub enum Handled {
    /// The reply, ready.
    Reply(ResponseBody),
    /// A commit to store outside any lock, then [`Device::finish_commit`].
    Save(PendingCommit),
}

/// Coefficients recovered from the store at boot.
pub struct Boot {
    /// The stored set, if one was valid.
    pub stored: Option<(Coefficients, u32)>,
    /// The unlock challenge for this boot.
    pub challenge: u32,
}

/// The board's state.
pub struct Device {
    bank: Bank,
    inputs: Inputs,
    pipeline: Pipeline,
    fit: Option<OnboardFit>,
    last_error: Option<DeviceError>,
}

impl Device {
    /// The device after boot: the stored set if valid, else the defaults
    /// (and `last_error` says so).
    pub fn new(boot: Boot) -> Self {
        let (bank, last_error) = Bank::boot(boot.stored, boot.challenge);
        let c = *bank.coefficients();
        Self { bank, inputs: Inputs::default(), pipeline: Pipeline::new(c.field_nt, c.inclination()), fit: None, last_error }
    }

    /// The calibration in use.
    pub fn calibration(&self) -> &Calibration<f32> {
        self.bank.calibration()
    }

    /// The output rate asked for, Hz.
    pub fn output_rate_hz(&self) -> u8 {
        self.pipeline.output_rate_hz
    }

    /// What is streamed.
    pub fn stream(&self) -> StreamMode {
        self.pipeline.stream
    }

    /// Processes one decimated raw sample through the [`pipeline`]: the
    /// current and temperature terms (see the module doc for stale or
    /// missing inputs), the on-board fit, the coefficients and the heading
    /// (with a fresh attitude, and a fresh current when the current term
    /// needs one); returns the sample to stream, if streaming.
    pub fn on_raw_sample(&mut self, raw: &RawSample, now_ms: u32) -> Option<Sample> {
        self.pipeline.process(raw, now_ms, self.bank.calibration(), &self.inputs, self.fit.as_mut())
    }

    fn refuse(&mut self, e: DeviceError) -> ResponseBody {
        self.last_error = Some(e);
        ResponseBody::Error(e)
    }

    /// A room's answer as the reply, its refusal (if it is one) kept as the
    /// last error.
    fn reply(&mut self, body: ResponseBody) -> Handled {
        if let ResponseBody::Error(e) = body {
            self.last_error = Some(e);
        }
        Handled::Reply(body)
    }

    /// Serves one request. `board` holds the counters the device does not
    /// own (acquisition, link, UART, feed), for a status report.
    pub fn handle(&mut self, req: &RequestBody, now_ms: u32, store: &mut impl CoefficientStore, board: &BoardCounters) -> ResponseBody {
        match self.handle_request(req, now_ms, board) {
            Handled::Reply(body) => body,
            Handled::Save(pending) => {
                let saved = store.save(pending.bytes());
                self.finish_commit(pending, saved)
            }
        }
    }

    /// [`Device::handle`] without the store: a commit that passed every
    /// check comes back as [`Handled::Save`], for the caller to store
    /// outside any lock (an erase stalls the CPU for up to 800 ms) and hand
    /// back to [`Device::finish_commit`].
    ///
    /// One arm per endpoint of the protocol's table ([`Call`]; the compiler
    /// holds the match exhaustive), each answered through its request's
    /// [`Endpoint::answer`], which takes only that endpoint's response kind;
    /// each arm hands the room that serves it the room's own payload.
    pub fn handle_request(&mut self, req: &RequestBody, now_ms: u32, board: &BoardCounters) -> Handled {
        let body = match Call::from(req.clone()) {
            // Answered by the link layer; here for completeness.
            Call::Ping(r) => r.answer(Ok(Pong { nonce: r.nonce })),
            Call::Identify(r) => return Handled::Reply(r.answer(Err(DeviceError::Unsupported))),
            Call::Status(r) => r.answer(Ok(self.health(now_ms, board))),
            Call::SetStream(r) => r.answer(self.pipeline.set_output(OutputRequest::Stream(r.0)).map(|()| Ack)),
            Call::SetOutputRate(r) => r.answer(self.pipeline.set_output(OutputRequest::Rate(r.hz)).map(|()| Ack)),
            Call::Attitude(r) => {
                let input = InputRequest::Attitude { roll_rad: r.roll_rad, pitch_rad: r.pitch_rad };
                r.answer(self.inputs.accept(input, now_ms).map(|()| Ack))
            }
            Call::Motion(r) => {
                let input = InputRequest::Motion { roll_rad: r.roll_rad, pitch_rad: r.pitch_rad, rate_rad_s: r.rate_rad_s };
                r.answer(self.inputs.accept(input, now_ms).map(|()| Ack))
            }
            Call::AttitudeEnv(r) => {
                let input = InputRequest::AttitudeEnv { roll_rad: r.roll_rad, pitch_rad: r.pitch_rad, motor_current_a: r.motor_current_a };
                r.answer(self.inputs.accept(input, now_ms).map(|()| Ack))
            }
            Call::FitStart(r) => r.answer(self.handle_fit(FitRequest::Start { model: r.model, field_nt: r.field_nt }, now_ms)),
            Call::FitStop(r) => r.answer(self.handle_fit(FitRequest::Stop, now_ms)),
            Call::FitQuery(r) => r.answer(self.handle_fit(FitRequest::Query, now_ms)),
            Call::ReadCoefficients(r) => r.answer(Ok(self.bank.in_use())),
            Call::Unlock(r) => r.answer(self.bank.unlock(r.key, now_ms).map(|()| Ack)),
            Call::WriteCoefficients(r) => r.answer(self.bank.stage(r.0, now_ms).map(|()| Ack)),
            Call::Commit(r) => match self.bank.prepare_commit(r.crc, now_ms) {
                Ok(pending) => return Handled::Save(pending),
                Err(e) => r.answer(Err(e)),
            },
            Call::SetMissionMode(r) => {
                self.bank.set_mission(r.enabled);
                r.answer(Ok(Ack))
            }
        };
        self.reply(body)
    }
}

/// What the output pipeline takes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum OutputRequest {
    /// What is streamed.
    Stream(magcal_protocol::StreamMode),
    /// The output rate, Hz.
    Rate(u8),
}

/// What the vehicle sends.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum InputRequest {
    /// Roll and pitch, rad.
    Attitude {
        /// Roll, rad.
        roll_rad: f32,
        /// Pitch, rad.
        pitch_rad: f32,
    },
    /// Roll, pitch and body rates.
    Motion {
        /// Roll, rad.
        roll_rad: f32,
        /// Pitch, rad.
        pitch_rad: f32,
        /// Body rates, rad/s.
        rate_rad_s: [f32; 3],
    },
    /// Roll, pitch and the thrusters' current.
    AttitudeEnv {
        /// Roll, rad.
        roll_rad: f32,
        /// Pitch, rad.
        pitch_rad: f32,
        /// Motor current, A.
        motor_current_a: f32,
    },
}

/// What the on-board fit takes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FitRequest {
    /// Start (or restart) a fit.
    Start {
        /// The model.
        model: magcal_protocol::OnboardModel,
        /// Reference intensity, nT.
        field_nt: f32,
    },
    /// Stop the fit.
    Stop,
    /// Report the fit.
    Query,
}

#[cfg(test)]
mod tests;
