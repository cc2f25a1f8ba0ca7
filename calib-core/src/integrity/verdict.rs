//! The vocabulary of the integrity: the states a sample's heading can be
//! in, and the judgement of one sample.

/// The integrity of one sample's heading.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum IntegrityState {
    /// The field fits the calibration's reference and the gyro: the heading
    /// may be used with its σ.
    Ok = 0,
    /// This sample's field does not fit (a nearby magnetic object, passing).
    Disturbed = 1,
    /// The field has not fitted for a sustained time: the stored
    /// calibration no longer fits this vehicle (new hard iron, payload).
    CalInvalid = 2,
    /// No attitude: no heading.
    NoAttitude = 3,
    /// The field passes every check, but the inclination it was judged by
    /// was learned from the very stream judged: no reference independent of
    /// it (a calibration without a reference inclination). The heading is
    /// given with its σ, but a wrong calibration can pass such checks, so
    /// it is not called `ok`.
    Unjudged = 4,
}

impl IntegrityState {
    /// The word used in CSV and JSON (`docs/INTERFACES.md`).
    pub fn name(self) -> &'static str {
        match self {
            IntegrityState::Ok => "ok",
            IntegrityState::Disturbed => "disturbed",
            IntegrityState::CalInvalid => "cal_invalid",
            IntegrityState::NoAttitude => "no_attitude",
            IntegrityState::Unjudged => "unjudged",
        }
    }

    /// From the wire byte (`self as u8`).
    pub fn from_u8(v: u8) -> Option<Self> {
        match v {
            0 => Some(IntegrityState::Ok),
            1 => Some(IntegrityState::Disturbed),
            2 => Some(IntegrityState::CalInvalid),
            3 => Some(IntegrityState::NoAttitude),
            4 => Some(IntegrityState::Unjudged),
            _ => None,
        }
    }

    /// Every state, in wire order.
    pub const ALL: [IntegrityState; 5] = [
        IntegrityState::Ok,
        IntegrityState::Disturbed,
        IntegrityState::CalInvalid,
        IntegrityState::NoAttitude,
        IntegrityState::Unjudged,
    ];
}

/// The judgement of one sample.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Verdict<T> {
    /// The integrity state.
    pub state: IntegrityState,
    /// The heading's 1σ, radians (NaN without attitude).
    pub heading_sigma_rad: T,
    /// Normalised magnitude residual `z_F`.
    pub field_z: T,
    /// Normalised dip residual `z_I` (0 before an inclination is known).
    pub dip_z: T,
}
