//! The one health snapshot ([`Device::health`]): the device's own state and
//! counters, and those the app keeps ([`BoardCounters`]).

use magcal_protocol::Health;

use super::Device;

/// The counters a status report needs that the device does not own: the
/// acquisition's, the link's, the UARTs' and the sensor feed's. The app
/// reads them when a request arrives and hands them to [`Device::handle`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct BoardCounters {
    /// Set/reset pairs acquired.
    pub pairs: u32,
    /// Pairs with a saturated channel.
    pub saturated: u32,
    /// ADC errors.
    pub acq_errors: u32,
    /// Acquisition deadlines missed.
    pub overruns: u32,
    /// Received bytes dropped (queue full, UART errors).
    pub rx_dropped: u32,
    /// Reply or sample frames dropped (transmit queue full).
    pub tx_dropped: u32,
    /// Damaged frames received.
    pub bad_frames: u32,
    /// Requests served.
    pub requests: u32,
    /// Sensor-feed frames applied (QEMU board).
    pub feed_updates: u32,
    /// Longest gap between two acquired pairs, ms.
    pub max_acq_gap_ms: u32,
    /// Coefficient saves done.
    pub store_saves: u32,
    /// Longest save, ms.
    pub max_store_ms: u32,
}

/// Counters the device keeps (the link and acquisition keep their own).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct DeviceCounters {
    /// Output samples produced.
    pub samples: u32,
    /// Samples whose heading was withheld for a stale or missing current.
    pub current_stale: u32,
    /// Samples without a valid temperature.
    pub temp_missing: u32,
}

impl Device {
    /// The one health snapshot: the device's own state and `board`'s counters.
    pub fn health(&self, now_ms: u32, board: &BoardCounters) -> Health {
        let p = &self.pipeline;
        let ih = p.integrity.as_ref().map(|o| *o.health());
        Health {
            uptime_ms: now_ms,
            pairs: board.pairs,
            samples: p.counters.samples,
            saturated: board.saturated,
            acq_errors: board.acq_errors,
            overruns: board.overruns,
            rx_dropped: board.rx_dropped,
            tx_dropped: board.tx_dropped,
            bad_frames: board.bad_frames,
            requests: board.requests,
            mission_mode: self.lock.mission(),
            unlocked: self.lock.is_unlocked(now_ms),
            unlock_challenge: self.lock.challenge(),
            coefficient_source: self.source,
            coefficient_seq: self.seq,
            last_error: self.last_error,
            output_rate_hz: p.output_rate_hz,
            stream: p.stream,
            feed_updates: board.feed_updates,
            max_acq_gap_ms: board.max_acq_gap_ms,
            store_saves: board.store_saves,
            max_store_ms: board.max_store_ms,
            current_stale: p.counters.current_stale,
            temp_missing: p.counters.temp_missing,
            temp_c: p.last_temp_c,
            env_degraded: p.env_degraded,
            integrity_samples: ih.map_or([0; 5], |h| h.samples_per_state),
            // Saturating: `as` clamps to the `u32` range (NaN to 0).
            longest_disturbance_ms: ih.map_or(0, |h| (h.longest_disturbance_s * 1000.0) as u32),
            hard_iron_nt: p.integrity.as_ref().and_then(|o| o.hard_iron()).map(|e| e.offset_nt),
            hard_iron_applied: p.integrity.as_ref().is_some_and(|o| o.applied_offset_nt().is_some()),
            hard_iron_applications: ih.map_or(0, |h| h.hard_iron_applied),
        }
    }
}
