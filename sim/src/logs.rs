//! A simulated field test as the two logs a real one leaves: the board's
//! field log on the board's clock and the navigation computer's log on its
//! own, slower and shorter (`magcal merge`'s inputs), with a known clock
//! offset and drift between them.

use calib_core::conformance::SplitMix64;
use host_tools::data::BoardLog;
use host_tools::data::NavLog;

use crate::field_test::Simulation;

/// Navigation-clock time of the simulation's first row, s.
pub const NAV_T0_S: f64 = 1000.0;

/// Which heading the navigation log carries (`magcal merge` aligns the
/// clocks on whatever both logs share).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum NavHeading {
    /// The AHRS heading (`heading_deg`: the true heading with 0.15° of
    /// noise) and the GPS course (`ref_heading_deg`) where the simulation
    /// has it.
    #[default]
    Ahrs,
    /// No heading column and no course: roll, pitch and position only (a
    /// vehicle whose navigation computer logs no heading).
    None,
    /// No AHRS heading: the GPS course over ground (`ref_heading_deg`),
    /// present only at the surface and empty while diving, is the only
    /// heading — late by the simulation's GPS delay and off the heading by
    /// the crab angle, as a real one is.
    CourseOnly,
}

/// How the logs are cut from a simulation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LogSplit {
    /// `t_nav − t_board` at the board log's first sample, s.
    pub offset_s: f64,
    /// How much faster the navigation clock runs, ppm.
    pub drift_ppm: f64,
    /// The navigation log keeps every `nav_every`-th row (1 or more).
    pub nav_every: usize,
    /// The navigation log starts this long after the board log and ends
    /// this long before it, s.
    pub trim_s: (f64, f64),
    /// Seed of the AHRS heading's noise.
    pub seed: u64,
    /// Which heading the navigation log carries.
    pub nav_heading: NavHeading,
}

/// Splits a simulation (one row per board sample) into a board log whose
/// clock runs `t_nav = t_board + offset_s + drift_ppm·10⁻⁶·(t_board − first)`
/// (board times in whole milliseconds, as the board stamps them) and a
/// navigation log of every `nav_every`-th row within `trim_s` of each end
/// (roll and pitch as recorded, the headings as [`LogSplit::nav_heading`]
/// says: the AHRS heading = the true heading with 0.15° of noise, the GPS
/// course as simulated; the position as simulated). The navigation log's
/// `t` is [`NAV_T0_S`] plus the simulation's time.
pub fn split(sim: &Simulation, s: &LogSplit) -> (BoardLog, NavLog) {
    let rec = &sim.recording;
    let t: Vec<f64> = match &rec.t_s {
        Some(t) => t.clone(),
        None => (0..rec.len()).map(|i| i as f64).collect(),
    };
    let (Some(&first), Some(&end)) = (t.first(), t.last()) else {
        return (BoardLog::default(), NavLog::default());
    };
    // The board clock from the formula above, written here rather than
    // taken from `merge`'s own clock model: t_board solved from
    // t_nav = t_board + offset + d·(t_board − t_board0), t_board0 the board
    // time of the first row.
    let d = s.drift_ppm * 1e-6;
    let t_board0 = NAV_T0_S + first - s.offset_s;
    let board_t = |t_nav: f64| (t_nav - s.offset_s + d * t_board0) / (1.0 + d);
    let board = BoardLog {
        t_s: t.iter().map(|&ts| (board_t(NAV_T0_S + ts) * 1000.0).round() / 1000.0).collect(),
        mag: rec.mag.clone(),
        temp_c: None,
        health: None,
    };
    let rows: Vec<usize> = (0..t.len()).step_by(s.nav_every.max(1)).filter(|&i| t[i] >= first + s.trim_s.0 && t[i] <= end - s.trim_s.1).collect();
    let pick = |c: &Option<Vec<f64>>| c.as_ref().map(|c| rows.iter().map(|&i| c.get(i).copied().unwrap_or(f64::NAN)).collect::<Vec<f64>>());
    let mut rng = SplitMix64::new(s.seed);
    let mut ahrs_heading = || rows.iter().map(|&i| (sim.true_heading_deg.get(i).copied().unwrap_or(f64::NAN) + 0.15 * rng.gauss()).rem_euclid(360.0)).collect();
    let (heading_deg, ref_heading_deg) = match s.nav_heading {
        NavHeading::Ahrs => (Some(ahrs_heading()), pick(&rec.ref_heading_deg)),
        NavHeading::None => (None, None),
        NavHeading::CourseOnly => (None, pick(&rec.ref_heading_deg)),
    };
    let nav = NavLog {
        t_s: rows.iter().map(|&i| NAV_T0_S + t[i]).collect(),
        roll_deg: pick(&rec.roll_deg).unwrap_or_else(|| vec![f64::NAN; rows.len()]),
        pitch_deg: pick(&rec.pitch_deg).unwrap_or_else(|| vec![f64::NAN; rows.len()]),
        heading_deg,
        ref_heading_deg,
        lat_deg: pick(&rec.lat_deg),
        lon_deg: pick(&rec.lon_deg),
        ..NavLog::default()
    };
    (board, nav)
}
