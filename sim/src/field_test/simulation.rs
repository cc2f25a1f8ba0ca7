//! A simulated recording with its truth, and its two files.

use std::path::{Path, PathBuf};

use host_tools::data::Recording;

use super::{SimError, Truth};

/// A simulated recording with its truth. The true heading and attitude of
/// every row are in `true_heading_deg` etc.
#[derive(Debug, Clone)]
pub struct Simulation {
    /// The recording (INTERFACES.md columns).
    pub recording: Recording,
    /// True heading (degrees, true north) of every row.
    pub true_heading_deg: Vec<f64>,
    /// True roll, degrees.
    pub true_roll_deg: Vec<f64>,
    /// True pitch, degrees.
    pub true_pitch_deg: Vec<f64>,
    /// Whether the thrusters ran at each row.
    pub running: Vec<bool>,
    /// The effects' truth columns (written beside the recording):
    /// `true_field_{n,e,d}_nt`, `sensor_temp_c`, `bus_current_a`,
    /// `thruster_{k}_a`, `depth_m`, `true_lat_deg`, `true_lon_deg`,
    /// `true_course_deg`, `water_speed_mps`, `structure_distance_m`,
    /// `payload_on`, `truth_disturbance_nt`, as the effects need them.
    pub effect_columns: Vec<(String, Vec<f64>)>,
    /// The truth.
    pub truth: Truth,
}

impl Simulation {
    /// A simulation without rows yet.
    pub(super) fn empty(truth: Truth) -> Self {
        Self {
            recording: Recording::default(),
            true_heading_deg: vec![],
            true_roll_deg: vec![],
            true_pitch_deg: vec![],
            running: vec![],
            effect_columns: vec![],
            truth,
        }
    }

    /// An effect truth column by name.
    pub fn effect_column(&self, name: &str) -> Option<&[f64]> {
        self.effect_columns.iter().find(|(n, _)| n == name).map(|(_, c)| c.as_slice())
    }

    /// Appends a value to an effect truth column, creating it (after the
    /// others) on its first value.
    pub(super) fn push_column(&mut self, name: &str, v: f64) {
        match self.effect_columns.iter_mut().find(|(n, _)| n == name) {
            Some((_, c)) => c.push(v),
            None => self.effect_columns.push((name.to_string(), vec![v])),
        }
    }

    /// Writes `path` (the recording plus truth columns) and `<path>.truth.json`.
    pub fn write(&self, path: &Path) -> Result<(), SimError> {
        let running: Vec<f64> = self.running.iter().map(|&r| if r { 1.0 } else { 0.0 }).collect();
        let mut extra: Vec<(&str, &[f64])> = vec![
            (host_tools::data::col::TRUE_HEADING_DEG, &self.true_heading_deg),
            ("true_roll_deg", &self.true_roll_deg),
            ("true_pitch_deg", &self.true_pitch_deg),
            ("running", &running),
        ];
        extra.extend(self.effect_columns.iter().map(|(n, c)| (n.as_str(), c.as_slice())));
        self.recording.write_with_extra(path, &extra)?;
        let truth_path = truth_path(path);
        let text = serde_json::to_string_pretty(&self.truth).map_err(SimError::Truth)?;
        host_tools::files::write_text_atomic(&truth_path, &text)?;
        Ok(())
    }
}

/// `run.csv` → `run.truth.json`.
pub fn truth_path(path: &Path) -> PathBuf {
    path.with_extension("truth.json")
}
