//! The reference check on a recording: what a calibration shows against
//! the independent reference ([`crate::doc::reference`]: the world model's
//! field at the site with its allowance), the world model's field where a
//! recording was made, and a field the user gives held to physics, the world
//! model and the data.

use calib_core::cal::FieldCal;
use calib_core::heading::level;

use crate::data::Recording;
use crate::doc::reference::{world_allowance, Reference, ReferenceCheck, ReferenceSource, REFUSE_SIGMAS};
use crate::geomag::{Field, Site};

impl Reference {
    /// Checks what a calibration shows on `rec` against this reference:
    /// `fit_dip` is the fit's own dip estimate with its 1σ (degrees), used
    /// when the recording has no attitude to level with. Returns the check,
    /// stored in `self.check` too.
    pub fn check_calibration(&mut self, cal: &FieldCal<f64>, rec: &Recording, fit_dip: Option<(f64, f64)>) -> ReferenceCheck {
        let (dip, mag) = shown(cal, rec);
        let shown_dip = dip.map(|d| (d, 0.0)).or(fit_dip);
        let mut words = Vec::new();
        let mut allowance = None;
        if let (Some((d, fit_sigma)), Some(i), Some(si)) = (shown_dip, self.inclination_deg, self.inclination_sigma_deg) {
            let a = si.hypot(fit_sigma);
            allowance = Some(a);
            if (d - i).abs() > REFUSE_SIGMAS * a {
                words.push(format!(
                    "the calibrated field's dip is {d:.2}° where the reference gives {i:.2}° ± {a:.2}° (1σ, {}): {:.1}σ off",
                    self.describe(),
                    (d - i).abs() / a
                ));
            }
        }
        if self.source != ReferenceSource::CalibrationData && (mag - self.field_nt).abs() > REFUSE_SIGMAS * self.field_sigma_nt {
            words.push(format!(
                "the calibrated intensity is {mag:.0} nT where the reference gives {:.0} ± {:.0} nT (1σ, {})",
                self.field_nt,
                self.field_sigma_nt,
                self.describe()
            ));
        }
        let check = ReferenceCheck { inclination_deg: shown_dip.map(|d| d.0), inclination_allowance_deg: allowance, field_nt: mag, agrees: words.is_empty(), disagreement: words.join("; ") };
        self.check = Some(check.clone());
        check
    }
}

/// The median dip (levelled with roll and pitch, when the recording has
/// them) and the median intensity of a calibration applied to a recording.
pub fn shown(cal: &FieldCal<f64>, rec: &Recording) -> (Option<f64>, f64) {
    let mut dips = Vec::new();
    let mut mags = Vec::new();
    for (i, raw) in rec.mag.iter().enumerate() {
        if !raw.iter().all(|v| v.is_finite()) {
            continue;
        }
        let h = cal.apply(*raw);
        mags.push((h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt());
        let at = |c: &Option<Vec<f64>>| c.as_ref().and_then(|v| v.get(i).copied()).filter(|v| v.is_finite());
        if let (Some(r), Some(p)) = (at(&rec.roll_deg), at(&rec.pitch_deg)) {
            let l = level(h, r.to_radians(), p.to_radians());
            dips.push(l[2].atan2(l[0].hypot(l[1])).to_degrees());
        }
    }
    let dip = calib_core::series::median(&mut dips);
    (dip, calib_core::series::median(&mut mags).unwrap_or(f64::NAN))
}

/// The allowance of a user's inclination against the recording's own
/// levelled dip through the document's calibration, degrees: a first
/// step's calibration (before the back-stepping corrects its vertical) may
/// show a dip a few degrees off, never one of the other sign or tens of
/// degrees away (a vertical given with its sign flipped is off by twice
/// the dip: 112° at 56°).
pub const DATA_DIP_ALLOWANCE_DEG: f64 = 10.0;

/// The world model's field where a recording was made: IGRF-14 at the
/// median of its `lat_deg`/`lon_deg` (where it has positions), else at the
/// site, at the site's date. `None` without a site (no date) or when the
/// model cannot be evaluated there.
pub fn world_field_for(rec: &Recording, site: Option<Site>) -> Option<(Site, Field)> {
    let site = site?;
    let median_of = |c: &Option<Vec<f64>>| c.as_ref().and_then(|v| calib_core::series::median(&mut v.iter().copied().filter(|x| x.is_finite()).collect::<Vec<_>>()));
    let at = match (median_of(&rec.lat_deg), median_of(&rec.lon_deg)) {
        (Some(lat), Some(lon)) => Site { lat_deg: lat, lon_deg: lon, decimal_year: site.decimal_year },
        _ => site,
    };
    at.field().ok().map(|f| (at, f))
}

/// A value given by the user against what a source gives: words when they
/// differ by more than [`REFUSE_SIGMAS`] × `sigma` (`None`: they agree).
/// `what` names the value, `unit` its unit as written after a number
/// (`"°"`, `" nT"`), `source` where `expected` came from.
pub fn given_disagreement(what: &str, given: f64, expected: f64, sigma: f64, unit: &str, source: &str) -> Option<String> {
    let off = (given - expected).abs();
    (off > REFUSE_SIGMAS * sigma).then(|| {
        format!("{what} {given:.1}{unit} is {off:.1}{unit} from the {expected:.1}{unit} of {source} (allowance {REFUSE_SIGMAS} × {sigma:.1}{unit})")
    })
}

/// Checks a reference field given as its horizontal and down components
/// (nT): refused outright (`Err`) when it cannot be a geomagnetic field —
/// the horizontal intensity not positive, or the intensity outside
/// [`crate::doc::caldoc::FIELD_NT_RANGE`]; otherwise the disagreements
/// (empty: none) with the world model where it is known (`world`) and with
/// the dip the recording itself shows (`data_dip_deg`, levelled through
/// the calibration it will refine; allowance [`DATA_DIP_ALLOWANCE_DEG`]).
pub fn check_given_field(h_nt: f64, z_nt: f64, world: Option<&(Site, Field)>, data_dip_deg: Option<f64>) -> Result<Vec<String>, String> {
    if !(h_nt.is_finite() && z_nt.is_finite() && h_nt > 0.0) {
        return Err(format!(
            "a horizontal intensity of {h_nt} nT is not one of the Earth's field (positive everywhere but at the magnetic poles, where a heading has no meaning)"
        ));
    }
    let f = h_nt.hypot(z_nt);
    if let Some(why) = crate::doc::caldoc::field_nt_problem(f) {
        return Err(format!("the horizontal and down components give an intensity of {why}"));
    }
    let dip = z_nt.atan2(h_nt).to_degrees();
    let mut words = Vec::new();
    if let Some((site, field)) = world {
        let (si, sf) = world_allowance(field.total_nt());
        let source = format!("IGRF-14 at {:.3}°, {:.3}°, {:.2}", site.lat_deg, site.lon_deg, site.decimal_year);
        words.extend(given_disagreement("the inclination they give", dip, field.inclination_deg(), si, "°", &source));
        words.extend(given_disagreement("the intensity they give", f, field.total_nt(), sf, " nT", &source));
    }
    if let Some(d) = data_dip_deg {
        words.extend(given_disagreement("the inclination they give", dip, d, DATA_DIP_ALLOWANCE_DEG / REFUSE_SIGMAS, "°", "the recording's own levelled dip through the calibration"));
    }
    Ok(words)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_given_field_is_held_to_physics_the_world_model_and_the_data() {
        // IGRF-14 at 36.9° N, 50.6° E in 2021 (the simulator's site): about
        // H 27 300 nT, Z 40 600 nT, dip 56°.
        let site = Site::new(36.9, 50.6, "2021-01-01").unwrap();
        let world = (site, site.field().unwrap());
        let (h, z) = (world.1.horizontal_nt(), world.1.down_nt);
        assert!(check_given_field(h, z, Some(&world), Some(56.0)).unwrap().is_empty());
        // The vertical's sign flipped: the dip −56° against +56° both ways.
        let words = check_given_field(h, -z, Some(&world), Some(56.0)).unwrap();
        assert_eq!(words.len(), 2, "{words:?}");
        assert!(words[0].contains("IGRF-14") && words[1].contains("levelled dip"), "{words:?}");
        // No horizontal field, or µT typed for nT: no field at all.
        assert!(check_given_field(0.0, 48_000.0, None, None).unwrap_err().contains("horizontal"));
        assert!(check_given_field(27.3, 40.6, None, None).unwrap_err().contains("µT"));
        // 4 % off in intensity is within 3 × 3 %: kept.
        assert!(check_given_field(h * 1.04, z * 1.04, Some(&world), None).unwrap().is_empty());
    }
}
