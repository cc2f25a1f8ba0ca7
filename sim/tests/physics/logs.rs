//! The log shapes `magcal merge` is tested on ([`magcal_sim::logs`]): a
//! navigation log without a heading, and a 1 Hz one whose only heading is
//! the GPS course at the surface, from a run of circles then legs with dives.

use magcal_sim::field_test::{self, paper_site, RunKind, RunParams, SensorModel, CIRCLE_PERIOD_S};
use magcal_sim::logs::{split, LogSplit, NavHeading, NAV_T0_S};

/// The circles: at the surface with the GPS course all along, every
/// heading turned through at 360° per circle, the course then the
/// outbound one without a jump; the legs dive (course empty); pitch and
/// roll never change faster than the limit.
#[test]
fn a_run_of_circles_then_legs_circles_at_the_surface_then_dives() {
    let p = RunParams::circles_then_legs(400.0);
    let sim = field_test::run(
        &SensorModel::paper_like(),
        &paper_site(),
        &p,
        3,
        1.0,
        RunKind::Run,
    )
    .unwrap();
    let rec = &sim.recording;
    let (t, course) = (
        rec.t_s.as_ref().unwrap(),
        rec.ref_heading_deg.as_ref().unwrap(),
    );
    // The GPS course is 2 s late: there from the third row to the circles' end.
    assert!(t
        .iter()
        .zip(course)
        .filter(|(t, _)| **t >= 2.0 && **t < 400.0)
        .all(|(_, c)| c.is_finite()));
    // 400 s of 45 s circles: 3200° of heading, every heading many times.
    let h = &sim.true_heading_deg;
    let turned: f64 = h[..400]
        .windows(2)
        .map(|w| calib_core::heading::wrap_pi((w[1] - w[0]).to_radians()).to_degrees())
        .sum();
    assert!(
        (turned - 399.0 * 360.0 / CIRCLE_PERIOD_S).abs() < 5.0,
        "{turned}"
    );
    // Continuous into the first leg (the crab and the leg's wiggle change it by a degree or two).
    let step = calib_core::heading::wrap_pi((h[401] - h[399]).to_radians()).to_degrees();
    assert!(step.abs() < 20.0, "{step}");
    // Dives: the course empty for most of the legs.
    let empty =
        course[400..].iter().filter(|c| c.is_nan()).count() as f64 / (course.len() - 400) as f64;
    assert!(empty > 0.9, "{empty}");
    // Pitch and roll change at most 2°/s (a sample apart, plus the AHRS's noise).
    let (pitch, roll) = (&sim.true_pitch_deg, &sim.true_roll_deg);
    assert!(pitch
        .windows(2)
        .chain(roll.windows(2))
        .all(|w| (w[1] - w[0]).abs() <= 2.0 + 1e-9));
    assert!(
        pitch.iter().any(|p| *p < -11.0) && pitch.iter().any(|p| *p > 11.0),
        "it dives and climbs"
    );
}

/// The navigation log's headings: the AHRS heading and the course, none, or
/// the course alone.
#[test]
fn the_navigation_log_carries_the_heading_asked_for() {
    let sim = field_test::run(
        &SensorModel::paper_like(),
        &paper_site(),
        &RunParams::circles_then_legs(400.0),
        3,
        1.0,
        RunKind::Run,
    )
    .unwrap();
    let cut = |nav_heading| {
        split(
            &sim,
            &LogSplit {
                offset_s: 10.0,
                drift_ppm: 50.0,
                nav_every: 1,
                trim_s: (0.0, 0.0),
                seed: 3,
                nav_heading,
            },
        )
        .1
    };
    let ahrs = cut(NavHeading::Ahrs);
    assert!(ahrs.heading_deg.is_some() && ahrs.ref_heading_deg.is_some());
    let none = cut(NavHeading::None);
    assert!(none.heading_deg.is_none() && none.ref_heading_deg.is_none() && none.lat_deg.is_some());
    let course = cut(NavHeading::CourseOnly);
    assert!(course.heading_deg.is_none());
    assert_eq!(
        course
            .ref_heading_deg
            .as_ref()
            .unwrap()
            .iter()
            .filter(|c| c.is_finite())
            .count(),
        ahrs.ref_heading_deg
            .as_ref()
            .unwrap()
            .iter()
            .filter(|c| c.is_finite())
            .count()
    );
    assert_eq!(course.t_s[0], NAV_T0_S);
}
