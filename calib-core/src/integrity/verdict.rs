//! The vocabulary of the integrity: the states a sample's heading can be
//! in ([`IntegrityState`], listed once in [`IntegrityState::ALL`]), what a
//! state is decided from ([`Evidence`]), the one function that decides it
//! ([`decide`]), and the judgement of one sample ([`Verdict`]).
//!
//! Every place that labels a sample — the monitor, the on-line path the
//! board runs and `magcal apply` replays, the board without a reference,
//! `apply`'s rows without a field — gathers its [`Evidence`] and calls
//! [`decide`]; nothing else maps evidence to a state. Names, wire codes and
//! counts iterate [`IntegrityState::ALL`].

/// The integrity of one sample's heading; on the wire (feature `serde`) as
/// its variant's index, [`IntegrityState::code`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[repr(u8)]
pub enum IntegrityState {
    /// The field fits the calibration's reference and the gyro: the heading
    /// may be used with its σ.
    Ok = 0,
    /// This sample's field does not fit (a nearby magnetic object, passing).
    Disturbed = 1,
    /// The field has not fitted for a sustained time, or its horizontal
    /// intensity varies twice a turn: the stored calibration no longer fits
    /// this vehicle (new hard iron, payload, a soft-iron error).
    CalInvalid = 2,
    /// No attitude (or no field): no heading.
    NoAttitude = 3,
    /// The field passes every check, but the inclination it was judged by
    /// was learned from the very stream judged: no reference independent of
    /// it (a calibration without a reference inclination). The heading is
    /// given with its σ, but a wrong calibration can pass such checks, so
    /// it is not called `ok`.
    Unjudged = 4,
}

impl IntegrityState {
    /// Every state, in wire order ([`IntegrityState::code`] is the index).
    pub const ALL: [IntegrityState; 5] = [
        IntegrityState::Ok,
        IntegrityState::Disturbed,
        IntegrityState::CalInvalid,
        IntegrityState::NoAttitude,
        IntegrityState::Unjudged,
    ];

    /// How many states there are: the length of every per-state array.
    pub const COUNT: usize = Self::ALL.len();

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

    /// The state of a word ([`IntegrityState::name`]).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.iter().copied().find(|s| s.name() == name)
    }

    /// The wire byte, also the index of per-state arrays
    /// (`[_; IntegrityState::COUNT]`) and of [`IntegrityState::ALL`].
    #[inline(always)]
    pub const fn code(self) -> u8 {
        self as u8
    }

    /// The index of per-state arrays (`[_; IntegrityState::COUNT]`): the
    /// wire byte.
    #[inline(always)]
    pub const fn index(self) -> usize {
        self as usize
    }

    /// From the wire byte ([`IntegrityState::code`]).
    pub fn from_code(code: u8) -> Option<Self> {
        Self::ALL.iter().copied().find(|s| s.code() == code)
    }

    /// Whether the state is a stretch of headings that were there but did
    /// not fit (`disturbed` or `cal_invalid`): what the longest disturbance
    /// counts. Every other state ends a stretch.
    #[inline(always)]
    pub const fn is_disturbance(self) -> bool {
        matches!(self, IntegrityState::Disturbed | IntegrityState::CalInvalid)
    }
}

/// The on-line hard iron's part in a sample's evidence
/// (`crate::online::OnlineIntegrity`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum HardIronEvidence {
    /// No on-line hard iron applied to the sample: the stored calibration's
    /// field.
    NotApplied,
    /// Applied, not yet confirmed by a turn the gyro agreed with (or no
    /// gyro): the stored calibration is invalid and the estimate unproven.
    Unconfirmed,
    /// Applied and confirmed by the gyro.
    Confirmed,
    /// The gyro disagreed with the headings it gives: withdrawn.
    Refuted,
}

/// What a sample's state is decided from: what the sample carried, and
/// what the monitor (and the on-line hard iron) found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Evidence {
    /// The sample carries a field (`magcal apply`'s rows with a component
    /// missing or not finite have none).
    pub field: bool,
    /// The sample has an attitude, so a heading.
    pub attitude: bool,
    /// A monitor judged the sample: the calibration gave a reference (at
    /// least its intensity `F`) to judge against.
    pub judged: bool,
    /// The field has misfitted for a sustained time (the misfit fraction
    /// above `Tuning::misfit_enter`, not yet back below
    /// `Tuning::misfit_exit`), or its horizontal intensity varies twice a
    /// turn (a soft-iron error, `Monitor::two_cycle_found`): the stored
    /// calibration no longer fits.
    pub cal_invalid: bool,
    /// The sample failed a test, or passed for no longer than
    /// `Tuning::exit_s` since one failed, or the misfit fraction is above
    /// `Tuning::misfit_enter`.
    pub disturbed: bool,
    /// The on-line hard iron's part.
    pub hard_iron: HardIronEvidence,
    /// The inclination the dip was judged by is a reference's, not learned
    /// from the stream alone.
    pub independent_inclination: bool,
}

impl Evidence {
    /// A sample no monitor judged: one without a field (`field` false), or
    /// on a board with no reference to judge against.
    pub const fn without_monitor(field: bool, attitude: bool) -> Self {
        Self {
            field,
            attitude,
            judged: false,
            cal_invalid: false,
            disturbed: false,
            hard_iron: HardIronEvidence::NotApplied,
            independent_inclination: false,
        }
    }

    /// A heading whose field passed the monitor's tests and their time
    /// logic: its σ is the sample's own (the on-line hard iron and the
    /// inclination's independence aside).
    #[inline(always)]
    pub const fn fits(&self) -> bool {
        self.field && self.attitude && self.judged && !self.cal_invalid && !self.disturbed
    }
}

/// The integrity state of a sample from its evidence: the one rule.
///
/// In order: no field or no attitude, no heading (`no_attitude`); nothing
/// to judge against, a sustained misfit, or an on-line hard iron the gyro
/// refuted (`cal_invalid`); a failing test or its hysteresis (`disturbed`);
/// an on-line hard iron not yet confirmed (`cal_invalid`: the stored
/// calibration is invalid and the estimate unproven); a dip judged only
/// against itself (`unjudged`); otherwise `ok`.
#[inline(always)]
pub const fn decide(e: &Evidence) -> IntegrityState {
    // Non-short-circuit `&` and `|`: fewer branches on the board's
    // per-sample path, the same rule.
    let refuted = matches!(e.hard_iron, HardIronEvidence::Refuted);
    let unconfirmed = matches!(e.hard_iron, HardIronEvidence::Unconfirmed);
    if !(e.field & e.attitude) {
        IntegrityState::NoAttitude
    } else if !e.judged | e.cal_invalid | refuted {
        IntegrityState::CalInvalid
    } else if e.disturbed {
        IntegrityState::Disturbed
    } else if unconfirmed {
        IntegrityState::CalInvalid
    } else if !e.independent_inclination {
        IntegrityState::Unjudged
    } else {
        IntegrityState::Ok
    }
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
