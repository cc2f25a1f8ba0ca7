//! Which environment terms the data allow, the run's reference field, and
//! the priors: the starting model and each parameter's prior and weight.

use super::model::{Model, B0, BR0, C0, DI, GH, GZ, K0, M0, MP, MR};
use super::{JointConfig, JointNote, SwingSample, NOTE_CURRENT, NOTE_GRADIENT, NOTE_TEMPERATURE, NP};
use crate::backstep::RunSample;
use crate::cal::{EnvTerms, FieldCal};
use crate::Real;

/// Mean, standard deviation, min and max of the finite values, and their count.
fn spread<T: Real>(values: impl Iterator<Item = T>) -> (T, T, T, T, u32) {
    let (mut n, mut s, mut s2, mut lo, mut hi) = (0u32, T::ZERO, T::ZERO, T::from_f64(f64::INFINITY), T::from_f64(f64::NEG_INFINITY));
    for v in values.filter(|v| v.is_finite()) {
        n += 1;
        s += v;
        s2 += v * v;
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if n == 0 {
        return (T::NAN, T::ZERO, T::NAN, T::NAN, 0);
    }
    let c = T::from_f64(f64::from(n));
    let mean = s / c;
    (mean, (s2 / c - mean * mean).max(T::ZERO).sqrt(), lo, hi, n)
}

/// Which environment terms the data allow, and the run's typical values.
pub(super) struct TermChoice<T> {
    pub(super) use_current: bool,
    pub(super) use_temp: bool,
    pub(super) use_gradient: bool,
    track: [T; 2],
    pub(super) current_mean: T,
    pub(super) temp_mean: T,
    pub(super) temp_n: u32,
    pub(super) ref_c: T,
    pub(super) notes: [Option<JointNote<T>>; 4],
}

/// Decides the current and temperature terms from their spread over the
/// run and the swing test (a note says why a term is not estimated).
pub(super) fn choose_terms<T: Real>(run: &[RunSample<T>], swing: &[SwingSample<T>], cfg: &JointConfig<T>) -> TermChoice<T> {
    let mut notes = [None; 4];
    // Current: observable when it varies.
    let (current_mean, current_sd, _, _, current_n) = spread(run.iter().map(|s| s.current_a).chain(swing.iter().map(|s| s.current_a)));
    let use_current = if !cfg.terms.motor_current {
        false
    } else if current_n == 0 {
        notes[NOTE_CURRENT] = Some(JointNote::NoCurrentColumn);
        false
    } else if !(current_sd >= cfg.min_current_spread_a) {
        notes[NOTE_CURRENT] = Some(JointNote::CurrentNotVaried { spread_a: current_sd, min_a: cfg.min_current_spread_a });
        false
    } else {
        true
    };
    let (temp_mean, _, t_lo, t_hi, temp_n) = spread(run.iter().map(|s| s.temp_c).chain(swing.iter().map(|s| s.temp_c)));
    let use_temp = if !cfg.terms.temperature {
        false
    } else if temp_n == 0 {
        notes[NOTE_TEMPERATURE] = Some(JointNote::NoTemperatureColumn);
        false
    } else if !(t_hi - t_lo >= cfg.min_temp_spread_c) {
        notes[NOTE_TEMPERATURE] = Some(JointNote::TemperatureConstant { spread_c: t_hi - t_lo, min_c: cfg.min_temp_spread_c });
        false
    } else {
        true
    };
    let ref_c = match cfg.ref_c {
        Some(r) if r.is_finite() => r,
        _ if temp_n > 0 => (t_lo + t_hi) / T::from_f64(2.0),
        _ => EnvTerms::<T>::none().ref_c,
    };
    // The gradient: where the run goes far enough from the site, along
    // the principal axis of its positions. (Across the track the positions
    // are dead reckoning's drift between fixes, a sawtooth with the dives:
    // a gradient across it would fit what the dives do, not the field.)
    let (track, span_m) = track_axis(run);
    let use_gradient = if !cfg.terms.field_gradient {
        false
    } else if !(span_m >= cfg.min_gradient_span_m) {
        notes[NOTE_GRADIENT] = Some(JointNote::TrackTooShort { span_m, min_m: cfg.min_gradient_span_m });
        false
    } else {
        true
    };
    TermChoice { use_current, use_temp, use_gradient, track, current_mean, temp_mean, temp_n, ref_c, notes }
}

/// The principal axis (north, east; unit) of the run's positions about the
/// site (second moments), and the farthest distance from the site along
/// it, m (0 without positions).
fn track_axis<T: Real>(run: &[RunSample<T>]) -> ([T; 2], T) {
    let (mut snn, mut see, mut sne) = (T::ZERO, T::ZERO, T::ZERO);
    for s in run {
        let [n, e] = s.position_m;
        if n.is_finite() && e.is_finite() {
            snn += n * n;
            see += e * e;
            sne += n * e;
        }
    }
    // The larger eigenvector of [[snn, sne], [sne, see]]: angle ½·atan2(2 sne, snn − see).
    let angle = (T::from_f64(2.0) * sne).atan2(snn - see) / T::from_f64(2.0);
    let axis = [angle.cos(), angle.sin()];
    let span = run
        .iter()
        .map(|s| s.position_m)
        .filter(|p| p[0].is_finite() && p[1].is_finite())
        .fold(T::ZERO, |a, p| a.max((p[0] * axis[0] + p[1] * axis[1]).abs()));
    (axis, span)
}

/// The run's mean reference field and IGRF's σ along and across it.
pub(super) struct ReferenceField<T> {
    pub(super) h_nt: T,
    pub(super) z_nt: T,
    f_nt: T,
    pub(super) sigma_along_nt: T,
    sigma_across_nt: T,
}

pub(super) fn reference_field<T: Real>(run: &[RunSample<T>], cfg: &JointConfig<T>) -> ReferenceField<T> {
    let (h_mean, z_mean) = {
        let c = T::from_f64(run.len() as f64);
        (run.iter().fold(T::ZERO, |a, s| a + s.h_ref_nt) / c, run.iter().fold(T::ZERO, |a, s| a + s.z_ref_nt) / c)
    };
    let f_mean = (h_mean * h_mean + z_mean * z_mean).sqrt();
    // IGRF's σ along F (the intensity) and across it (the inclination).
    let (sh, sz) = (cfg.field_prior_h_nt, cfg.field_prior_z_nt);
    let sigma_along_nt = ((sh * h_mean / f_mean) * (sh * h_mean / f_mean) + (sz * z_mean / f_mean) * (sz * z_mean / f_mean)).sqrt();
    let sigma_across_nt = ((sh * z_mean / f_mean) * (sh * z_mean / f_mean) + (sz * h_mean / f_mean) * (sz * h_mean / f_mean)).sqrt();
    ReferenceField { h_nt: h_mean, z_nt: z_mean, f_nt: f_mean, sigma_along_nt, sigma_across_nt }
}

/// The model with the chosen terms active and the assumed residual σ.
pub(super) fn initial_model<T: Real>(terms: &TermChoice<T>, swing_field_nt: T, cfg: &JointConfig<T>) -> Model<T> {
    let mut active = [true; NP];
    for k in 0..3 {
        active[BR0 + k] = !terms.use_current;
        active[C0 + k] = terms.use_current;
        active[K0 + k] = terms.use_temp;
    }
    active[DI] = cfg.terms.local_field;
    active[MR] = cfg.terms.misalignment;
    active[MP] = cfg.terms.misalignment;
    active[GH] = terms.use_gradient;
    active[GZ] = terms.use_gradient;
    Model {
        active,
        ref_c: terms.ref_c,
        w_run: T::ONE / cfg.weights.run_sigma_nt,
        w_swing: T::ONE / cfg.weights.swing_sigma_nt,
        swing_field_nt,
        track: terms.track,
    }
}

/// The prior (the step-1 calibration, neutral environment terms) and its
/// weight per parameter.
pub(super) fn priors<T: Real>(start: &FieldCal<T>, gain: T, field: &ReferenceField<T>, cfg: &JointConfig<T>) -> ([T; NP], [T; NP]) {
    let mut prior = [T::ZERO; NP];
    for i in 0..3 {
        for k in 0..3 {
            prior[M0 + 3 * i + k] = start.matrix[i][k];
        }
        prior[B0 + i] = start.bias[i];
    }
    let w = &cfg.weights;
    let mut prior_w = [T::ZERO; NP];
    for a in 0..NP {
        prior_w[a] = match a {
            _ if a < B0 => T::ONE / (w.matrix_prior_rel * gain),
            _ if a < BR0 => gain / w.bias_prior_nt,
            _ if a < C0 => gain / w.running_bias_prior_nt,
            _ if a < K0 => gain / cfg.current_prior_nt_per_a,
            _ if a < DI => T::ONE / cfg.gain_prior_per_c,
            DI => field.f_nt / field.sigma_across_nt,
            MR | MP => T::ONE / cfg.misalignment_prior_rad,
            _ => T::ONE / cfg.gradient_prior_nt_per_m,
        };
    }
    (prior, prior_w)
}
