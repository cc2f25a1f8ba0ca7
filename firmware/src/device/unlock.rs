//! The write lock on the coefficients: a per-boot challenge, an unlock that
//! expires after [`UNLOCK_TIMEOUT_MS`] and is spent by a commit, and mission
//! mode, which refuses every write.

use magcal_protocol::{DeviceError, UNLOCK_TIMEOUT_MS, UNLOCK_XOR};

/// The boot challenge the fuzz target's seed corpus is written for
/// (`fuzz/seeds/frame_decoder/`): its unlock frames carry
/// `FUZZ_CHALLENGE ^ UNLOCK_XOR`.
pub const FUZZ_CHALLENGE: u32 = 0x5EED;

/// The lock's state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct WriteLock {
    challenge: u32,
    unlocked_until_ms: Option<u32>,
    mission: bool,
}

impl WriteLock {
    /// Locked, outside mission mode, with this boot's challenge.
    pub(super) fn new(challenge: u32) -> Self {
        Self { challenge, unlocked_until_ms: None, mission: false }
    }

    /// The challenge an unlock must answer (XOR [`UNLOCK_XOR`]).
    pub(super) fn challenge(&self) -> u32 {
        self.challenge
    }

    /// Mission mode is on.
    pub(super) fn mission(&self) -> bool {
        self.mission
    }

    /// Writes are open: unlocked, not expired, not in mission mode.
    pub(super) fn is_unlocked(&self, now_ms: u32) -> bool {
        self.unlocked_until_ms.is_some_and(|t| now_ms.wrapping_sub(t) as i32 <= 0) && !self.mission
    }

    /// Answers the challenge. One key, one unlock: the challenge moves on,
    /// so a replayed `Unlock` frame is refused.
    pub(super) fn unlock(&mut self, key: u32, now_ms: u32) -> Result<(), DeviceError> {
        if self.mission {
            return Err(DeviceError::MissionMode);
        }
        if key != self.challenge ^ UNLOCK_XOR {
            return Err(DeviceError::BadKey);
        }
        self.unlocked_until_ms = Some(now_ms.wrapping_add(UNLOCK_TIMEOUT_MS));
        self.challenge = next_challenge(self.challenge, now_ms);
        Ok(())
    }

    /// Why a write (stage or commit) may not happen now, if it may not.
    pub(super) fn check_write(&self, now_ms: u32) -> Result<(), DeviceError> {
        if self.mission {
            Err(DeviceError::MissionMode)
        } else if !self.is_unlocked(now_ms) {
            Err(DeviceError::Locked)
        } else {
            Ok(())
        }
    }

    /// Spends the unlock (after a commit).
    pub(super) fn relock(&mut self) {
        self.unlocked_until_ms = None;
    }

    /// Enters or leaves mission mode; entering it also spends the unlock.
    pub(super) fn set_mission(&mut self, enabled: bool) {
        self.mission = enabled;
        if enabled {
            self.relock();
        }
    }
}

/// The next unlock challenge (FNV-1a of the old one and the time): not a
/// secret, only never the same twice in a row.
fn next_challenge(old: u32, now_ms: u32) -> u32 {
    let mut h: u32 = 0x811c_9dc5;
    for b in old.to_le_bytes().into_iter().chain(now_ms.to_le_bytes()) {
        h = (h ^ u32::from(b)).wrapping_mul(0x0100_0193);
    }
    if h == old { h.wrapping_add(1) } else { h }
}
