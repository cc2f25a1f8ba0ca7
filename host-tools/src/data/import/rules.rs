//! The rules every format's importer shares, written once: the course as a
//! heading only at speed, the time base (samples of another message carried
//! to the compass's times), the units of the column registry, attitude from a
//! quaternion, and the choice among several instances of one sensor.

use super::ImportError;
use crate::data::pairing::{bracket, Bracket};

/// An angle difference on −180…180° (the project's one).
pub use crate::data::pairing::wrap180;

/// nT per tesla (ROS's `sensor_msgs/MagneticField`).
pub const NT_PER_TESLA: f64 = 1e9;

/// The course over ground as a reference heading: only at a ground speed of
/// `min_speed_mps` or more (slower, the course is the GNSS's noise), NaN
/// otherwise. The course is not the heading: in a current they differ by the
/// crab angle, which the report says.
pub fn course_at_speed_deg(course_deg: f64, speed_mps: f64, min_speed_mps: f64) -> f64 {
    if course_deg.is_finite() && speed_mps.is_finite() && speed_mps >= min_speed_mps {
        course_deg.rem_euclid(360.0)
    } else {
        f64::NAN
    }
}

/// How a value of a [`Series`] is interpolated between two samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// Linearly.
    Linear,
    /// An angle, the short way round (roll, yaw, heading); the result on
    /// 0–360° for a heading, ±180° otherwise.
    Angle180,
    /// A heading or course, the short way round, on 0–360°.
    Heading360,
    /// Not interpolated: the latest sample's value (a fix, a count).
    Latest,
}

/// Samples of one message kind in time order, `K` values each: carried to
/// the compass's times by [`Series::at`] through the project's one
/// bracketing rule ([`crate::data::pairing::bracket`]).
#[derive(Debug, Clone)]
pub struct Series<const K: usize> {
    t_s: Vec<f64>,
    /// One column a value.
    v: [Vec<f64>; K],
    kinds: [Kind; K],
    /// Samples dropped because their time went back or was not finite.
    pub out_of_order: usize,
}

impl<const K: usize> Series<K> {
    /// An empty series whose values interpolate as `kinds` say.
    pub fn new(kinds: [Kind; K]) -> Self {
        Self { t_s: Vec::new(), v: std::array::from_fn(|_| Vec::new()), kinds, out_of_order: 0 }
    }

    /// Adds a sample; one older than the last is dropped and counted (the
    /// series stays in time order). Non-finite times are dropped too.
    pub fn push(&mut self, t_s: f64, v: [f64; K]) {
        match self.t_s.last() {
            _ if !t_s.is_finite() => self.out_of_order += 1,
            Some(&last) if t_s < last => self.out_of_order += 1,
            _ => {
                self.t_s.push(t_s);
                for (column, value) in self.v.iter_mut().zip(v) {
                    column.push(value);
                }
            }
        }
    }

    /// Whether no sample is held.
    pub fn is_empty(&self) -> bool {
        self.t_s.is_empty()
    }

    /// The values at `t_s`: interpolated between the samples around it when
    /// they are at most `max_age_s` apart, else the latest sample at or
    /// before it when not older than `max_age_s`; `None` without either.
    pub fn at(&self, t_s: f64, max_age_s: f64) -> Option<[f64; K]> {
        let b = match bracket(&self.t_s, t_s, max_age_s) {
            Some(b) => b,
            None => {
                let lo = self.t_s.partition_point(|&x| x <= t_s).checked_sub(1)?;
                if t_s - self.t_s[lo] > max_age_s {
                    return None;
                }
                Bracket { lo, hi: lo, weight: 0.0 }
            }
        };
        Some(std::array::from_fn(|k| match self.kinds[k] {
            Kind::Linear => b.lerp(&self.v[k]),
            Kind::Angle180 => b.lerp_angle_deg(&self.v[k], false),
            Kind::Heading360 => b.lerp_angle_deg(&self.v[k], true),
            Kind::Latest => self.v[k][b.lo],
        }))
    }
}

/// Roll, pitch and yaw (degrees; yaw on 0–360°) of the unit quaternion
/// `[w, x, y, z]` rotating the body frame to the world frame, by the
/// aerospace Z-Y-X convention (a NED world and an FRD body give the heading
/// from north, clockwise). The quaternion is normalised first; `None` when it
/// is not finite or near zero.
pub fn quaternion_to_euler_deg(q: [f64; 4]) -> Option<[f64; 3]> {
    let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
    if !n.is_finite() || n < 1e-6 {
        return None;
    }
    let [w, x, y, z] = q.map(|v| v / n);
    let roll = (2.0 * (w * x + y * z)).atan2(1.0 - 2.0 * (x * x + y * y));
    let pitch = (2.0 * (w * y - z * x)).clamp(-1.0, 1.0).asin();
    let yaw = (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z));
    Some([roll.to_degrees(), pitch.to_degrees(), yaw.to_degrees().rem_euclid(360.0)])
}

/// The instance of a sensor to import among those `found` (in the order the
/// log holds them): `wanted` when given and present, else the first. The
/// note to report when there was a choice; an error naming the instances
/// found when `wanted` is absent.
pub fn choose_instance(sensor: &str, found: &[u32], wanted: Option<u32>) -> Result<(u32, Option<String>), ImportError> {
    let mut sorted = found.to_vec();
    sorted.sort_unstable();
    sorted.dedup();
    match (wanted, sorted.first()) {
        (_, None) => Err(ImportError::NoInstance { sensor: sensor.to_string(), wanted, found: sorted }),
        (Some(w), _) if !sorted.contains(&w) => Err(ImportError::NoInstance { sensor: sensor.to_string(), wanted, found: sorted }),
        (Some(w), _) => Ok((w, (sorted.len() > 1).then(|| format!("{sensor}: instance {w} of {sorted:?} (--instance)")))),
        (None, Some(&first)) => Ok((
            first,
            (sorted.len() > 1).then(|| format!("{sensor}: {} instances in the log ({sorted:?}); instance {first} imported (--instance N for another)", sorted.len())),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_course_is_a_heading_only_at_speed() {
        assert!(course_at_speed_deg(90.0, 0.49, 0.5).is_nan());
        assert_eq!(course_at_speed_deg(-90.0, 0.5, 0.5), 270.0);
        assert!(course_at_speed_deg(f64::NAN, 3.0, 0.5).is_nan());
    }

    #[test]
    fn a_series_interpolates_headings_the_short_way_and_ages_out() {
        let mut s = Series::new([Kind::Heading360, Kind::Linear, Kind::Latest]);
        s.push(0.0, [350.0, 0.0, 1.0]);
        s.push(1.0, [10.0, 10.0, 2.0]);
        s.push(0.5, [0.0, 0.0, 0.0]); // back in time: dropped
        assert_eq!(s.out_of_order, 1);
        let v = s.at(0.75, 2.0).unwrap();
        assert!((v[0] - 5.0).abs() < 1e-12 && (v[1] - 7.5).abs() < 1e-12 && v[2] == 1.0, "{v:?}");
        assert!(s.at(-0.1, 2.0).is_none());
        assert_eq!(s.at(1.5, 2.0).unwrap()[0], 10.0);
        assert!(s.at(3.5, 2.0).is_none());
        // Neighbours too far apart: the latest, not a line across the gap.
        assert_eq!(s.at(0.25, 0.5).unwrap()[0], 350.0);
    }

    #[test]
    fn quaternions_give_the_aerospace_angles() {
        // 30° about z (yaw), by the half-angle form.
        let h = 15f64.to_radians();
        let e = quaternion_to_euler_deg([h.cos(), 0.0, 0.0, h.sin()]).unwrap();
        assert!((e[2] - 30.0).abs() < 1e-9 && e[0].abs() < 1e-9 && e[1].abs() < 1e-9, "{e:?}");
        // 20° about x (roll), unnormalised ×2.
        let r = 10f64.to_radians();
        let e = quaternion_to_euler_deg([2.0 * r.cos(), 2.0 * r.sin(), 0.0, 0.0]).unwrap();
        assert!((e[0] - 20.0).abs() < 1e-9, "{e:?}");
        assert!(quaternion_to_euler_deg([0.0; 4]).is_none());
    }

    #[test]
    fn instances_are_chosen_and_said() {
        assert_eq!(choose_instance("sensor_mag", &[1, 0], None).unwrap().0, 0);
        assert!(choose_instance("sensor_mag", &[1, 0], None).unwrap().1.unwrap().contains("2 instances"));
        assert_eq!(choose_instance("sensor_mag", &[0], None).unwrap(), (0, None));
        let e = choose_instance("sensor_mag", &[0, 1], Some(3)).unwrap_err().to_string();
        assert!(e.contains("[0, 1]") && e.contains('3'), "{e}");
    }
}
