//! The one health snapshot ([`Device::health`]): the device's own state and
//! counters ([`DeviceCounters`]), and those the app keeps ([`BoardCounters`]).
//! Both counter sets are the protocol's own types, declared once there.

use magcal_protocol::{BoardCounters, Health};

use super::Device;

impl Device {
    /// The one health snapshot: the device's own state and `board`'s counters.
    pub fn health(&self, now_ms: u32, board: &BoardCounters) -> Health {
        let p = &self.pipeline;
        let ih = p.integrity.as_ref().map(|o| *o.health());
        Health {
            uptime_ms: now_ms,
            board: *board,
            device: p.counters,
            mission_mode: self.bank.lock().mission(),
            unlocked: self.bank.lock().is_unlocked(now_ms),
            unlock_challenge: self.bank.lock().challenge(),
            coefficient_source: self.bank.source(),
            coefficient_seq: self.bank.seq(),
            last_error: self.last_error,
            output_rate_hz: p.output_rate_hz,
            stream: p.stream,
            temp_c: p.last_temp_c,
            env_degraded: p.env_degraded,
            integrity_samples: ih.map_or([0; magcal_protocol::Integrity::COUNT], |h| h.samples_per_state),
            // Saturating: `as` clamps to the `u32` range (NaN to 0).
            longest_disturbance_ms: ih.map_or(0, |h| (h.longest_disturbance_s * 1000.0) as u32),
            hard_iron_nt: p.integrity.as_ref().and_then(|o| o.hard_iron()).map(|e| e.offset_nt),
            hard_iron_applied: p.integrity.as_ref().is_some_and(|o| o.applied_offset_nt().is_some()),
            hard_iron_applications: ih.map_or(0, |h| h.hard_iron_applied),
        }
    }
}
