//! Swing-test coverage guidance: which attitudes and headings the swing test
//! has reached, and what the operator must still do, in plain words.

use magcal_protocol::FitReport;

pub use crate::procedure::{PITCH_GATE_DEG, ROLL_GATE_DEG};

/// What the swing test has covered.
#[derive(Debug, Clone, Default)]
pub struct SwingCoverage {
    sectors: [u32; 12],
    roll: (f64, f64),
    pitch: (f64, f64),
    /// The on-board fit's last report.
    pub fit: Option<FitReport>,
}

const COMPASS: [&str; 12] = ["north", "north-north-east", "east-north-east", "east", "east-south-east", "south-south-east", "south", "south-south-west", "west-south-west", "west", "west-north-west", "north-north-west"];

impl SwingCoverage {
    /// Adds an attitude and the heading measured with the current coefficients.
    pub fn add(&mut self, roll_deg: f64, pitch_deg: f64, heading_deg: f64) {
        if heading_deg.is_finite() {
            let s = (heading_deg.rem_euclid(360.0) / 30.0) as usize;
            if let Some(c) = self.sectors.get_mut(s.min(11)) {
                *c += 1;
            }
        }
        if roll_deg.is_finite() {
            self.roll = (self.roll.0.min(roll_deg), self.roll.1.max(roll_deg));
        }
        if pitch_deg.is_finite() {
            self.pitch = (self.pitch.0.min(pitch_deg), self.pitch.1.max(pitch_deg));
        }
    }

    /// Plain guidance: what the operator must still do. Empty when done.
    pub fn guidance(&self) -> Vec<String> {
        let mut out = Vec::new();
        if self.roll.1 < ROLL_GATE_DEG {
            out.push(format!("roll further to starboard (reached {:.0}°, need {ROLL_GATE_DEG:.0}°)", self.roll.1));
        }
        if self.roll.0 > -ROLL_GATE_DEG {
            out.push(format!("roll further to port (reached {:.0}°, need −{ROLL_GATE_DEG:.0}°)", self.roll.0));
        }
        if self.pitch.1 < PITCH_GATE_DEG {
            out.push(format!("pitch nose up further (reached {:.0}°, need {PITCH_GATE_DEG:.0}°)", self.pitch.1));
        }
        if self.pitch.0 > -PITCH_GATE_DEG {
            out.push(format!("pitch nose down further (reached {:.0}°, need −{PITCH_GATE_DEG:.0}°)", self.pitch.0));
        }
        let missing: Vec<&str> = self.sectors.iter().zip(COMPASS).filter(|(c, _)| **c < 3).map(|(_, n)| n).collect();
        if !missing.is_empty() {
            out.push(format!("turn through {}", missing.join(", ")));
        }
        out
    }

    /// Sectors visited (of 12).
    pub fn sectors_visited(&self) -> usize {
        self.sectors.iter().filter(|c| **c >= 3).count()
    }
}


/// The swing test's per-step tracking: coverage from the heading that the
/// board's present coefficients give, the on-board fit polled every 25
/// steps, and the line the progress display shows.
pub struct SwingTracker {
    /// What has been covered.
    pub coverage: SwingCoverage,
    cal: calib_core::cal::FieldCal<f64>,
}

impl SwingTracker {
    /// Tracks with `guess` (the board's coefficients before the session) to
    /// turn raw samples into headings.
    pub fn new(guess: &crate::doc::CalDoc) -> Self {
        Self { coverage: SwingCoverage::default(), cal: guess.field_cal() }
    }

    /// One step: returns the progress line (guidance and the on-board fit).
    pub fn step<P: std::io::Read + std::io::Write>(
        &mut self,
        i: usize,
        step: &super::vehicle::Step,
        sample: &magcal_protocol::Sample,
        link: &mut crate::board::BoardClient<P>,
    ) -> Result<String, super::error::SessionError> {
        if let Some(raw) = sample.raw {
            let h = self.cal.apply(raw.map(f64::from));
            let psi = calib_core::heading::magnetic_heading_rad(h, step.roll_deg.to_radians(), step.pitch_deg.to_radians()).to_degrees();
            self.coverage.add(step.roll_deg, step.pitch_deg, psi);
        }
        if i % 25 == 24 {
            self.coverage.fit = Some(link.fit_query()?);
        }
        let g = self.coverage.guidance();
        let fit = self.coverage.fit.map(|f| format!("on-board fit: {} samples, {}% of directions, {:.0} nT RMS", f.samples, f.coverage_pct, f.residual_rms_nt)).unwrap_or_default();
        Ok(if g.is_empty() { format!("coverage complete; {fit}") } else { format!("{}; {fit}", g.join("; ")) })
    }
}
