//! The NMEA 0183 stream mode ([`magcal_protocol::StreamMode::Nmea`]): each
//! output sample as three sentences, for navigation computers that read a
//! heading sensor (`docs/INTERFACES.md`, "The board's NMEA 0183 output"):
//!
//! ```text
//! $HCHDG,<magnetic heading>,0.0,E,<variation>,<E|W>*hh\r\n
//! $HCHDT,<true heading>,T*hh\r\n
//! $PMAGI,<heading 1σ, deg>,<integrity>*hh\r\n
//! ```
//!
//! * headings in degrees to 0.1° in [0, 360); the magnetic heading is the
//!   true heading less the stored declination, already corrected for the
//!   deviation (the swing terms), so the deviation field is `0.0,E`; the
//!   variation is the stored declination;
//! * a heading whose integrity is not `ok` (or no heading) is sent with an
//!   empty heading field in `HDG` and `HDT`, so a receiver rejects it;
//!   `$PMAGI` says why: `ok`, `disturbed`, `cal_invalid`, `no_attitude`,
//!   `unjudged` (`IntegrityState::name`),
//!   with the σ to 0.01° (empty without a heading);
//! * the checksum is the XOR of the bytes between `$` and `*`, two
//!   upper-case hex digits.
//!
//! No allocation, no float formatting (a fixed-point formatter of its own),
//! bounded buffers; nothing here can panic.

use magcal_protocol::{Integrity, Sample};

/// The longest sentence NMEA 0183 allows, `$` to `\n` included.
pub const MAX_SENTENCE_LEN: usize = 82;

/// One sample's sentences, concatenated.
pub type Burst = heapless::Vec<u8, { 3 * MAX_SENTENCE_LEN }>;

/// One sentence being built.
type Line = heapless::Vec<u8, MAX_SENTENCE_LEN>;

/// The sentences of one output sample: `$HCHDG`, `$HCHDT`, `$PMAGI`, for
/// a calibration of declination `declination_rad` (east positive).
pub fn sentences(sample: &Sample, declination_rad: f32) -> Burst {
    let mut out = Burst::new();
    let declination_deg = declination_rad.to_degrees();
    let true_deg = sample.heading_rad.filter(|_| sample.integrity == Integrity::Ok).map(f32::to_degrees);
    let magnetic_deg = true_deg.map(|t| t - declination_deg);
    let mut hdg = Line::new();
    let _ = hdg.extend_from_slice(b"HCHDG,");
    push_heading(&mut hdg, magnetic_deg);
    let _ = hdg.extend_from_slice(b",0.0,E,");
    push_fixed(&mut hdg, Some(declination_deg.abs()), 1);
    let _ = hdg.extend_from_slice(if declination_deg < 0.0 { b",W" } else { b",E" });
    let mut hdt = Line::new();
    let _ = hdt.extend_from_slice(b"HCHDT,");
    push_heading(&mut hdt, true_deg);
    let _ = hdt.extend_from_slice(b",T");
    let mut magi = Line::new();
    let _ = magi.extend_from_slice(b"PMAGI,");
    push_fixed(&mut magi, sample.heading_sigma_deg, 2);
    let _ = magi.push(b',');
    let _ = magi.extend_from_slice(sample.integrity.name().as_bytes());
    for body in [&hdg, &hdt, &magi] {
        seal(&mut out, body);
    }
    out
}

/// Appends `$body*hh\r\n`.
fn seal(out: &mut Burst, body: &[u8]) {
    let sum = checksum(body);
    let _ = out.push(b'$');
    let _ = out.extend_from_slice(body);
    let _ = out.extend_from_slice(&[b'*', hex_digit(sum >> 4), hex_digit(sum & 0xF), b'\r', b'\n']);
}

/// XOR of the bytes between `$` and `*`.
pub fn checksum(body: &[u8]) -> u8 {
    body.iter().fold(0, |a, b| a ^ b)
}

fn hex_digit(n: u8) -> u8 {
    match n {
        0..=9 => b'0' + n,
        _ => b'A' + (n & 0xF) - 10,
    }
}

/// A heading, degrees, wrapped to [0, 360) to 0.1° (359.96 is `0.0`);
/// nothing for `None` or a non-finite value.
fn push_heading(line: &mut Line, deg: Option<f32>) {
    // Compares, not `%` (fmodf is software on the Cortex-M4F): headings
    // here are within (−360, 720) (a heading less a declination).
    let wrapped = deg.filter(|d| d.is_finite() && (-360.0..720.0).contains(d)).map(|d| {
        if d < 0.0 {
            d + 360.0
        } else if d >= 360.0 {
            d - 360.0
        } else {
            d
        }
    });
    let tenths = wrapped.and_then(|d| scaled(d, 1)).map(|t| if t >= 3600 { t - 3600 } else { t });
    push_scaled(line, tenths, 1);
}

/// A non-negative value with `decimals` (1 or 2) decimals, rounded half
/// up; nothing for `None`, a negative, non-finite or huge (≥ 10⁶) value.
fn push_fixed(line: &mut Line, value: Option<f32>, decimals: u32) {
    push_scaled(line, value.and_then(|v| scaled(v, decimals)), decimals);
}

/// `v · 10^decimals`, rounded, when `0 ≤ v < 10⁶`.
fn scaled(v: f32, decimals: u32) -> Option<u32> {
    let scale = pow10(decimals) as f32;
    // Within the range checked, `as` is exact to the rounding.
    (v.is_finite() && (0.0..1.0e6).contains(&v)).then_some((v * scale + 0.5) as u32)
}

/// Writes `n / 10^decimals` with exactly `decimals` decimals.
fn push_scaled(line: &mut Line, n: Option<u32>, decimals: u32) {
    let Some(n) = n else { return };
    let d = decimals.min(2);
    let scale = pow10(d);
    push_uint(line, n / scale);
    if d > 0 {
        let _ = line.push(b'.');
        let frac = n % scale;
        if d == 2 && frac < 10 {
            let _ = line.push(b'0');
        }
        push_uint(line, frac);
    }
}

/// 10^`decimals`, `decimals` ≤ 2 (more is taken as 2): never zero.
fn pow10(decimals: u32) -> u32 {
    match decimals {
        0 => 1,
        1 => 10,
        _ => 100,
    }
}

/// Decimal digits of `n`.
fn push_uint(line: &mut Line, n: u32) {
    let mut digits = [0u8; 10];
    let mut k = 0;
    let mut m = n;
    loop {
        if let Some(slot) = digits.get_mut(k) {
            *slot = b'0' + (m % 10) as u8;
        }
        k += 1;
        m /= 10;
        if m == 0 || k >= digits.len() {
            break;
        }
    }
    for i in (0..k).rev() {
        if let Some(&c) = digits.get(i) {
            let _ = line.push(c);
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::indexing_slicing)]
    use super::*;

    fn sample(heading_deg: Option<f32>, sigma_deg: Option<f32>, integrity: Integrity) -> Sample {
        Sample {
            t_ms: 0,
            raw: None,
            field_nt: Some([1.0; 3]),
            heading_rad: heading_deg.map(f32::to_radians),
            saturated: false,
            feed_seq: None,
            temp_c: None,
            heading_sigma_deg: sigma_deg,
            integrity,
        }
    }

    fn lines(b: &Burst) -> Vec<String> {
        String::from_utf8(b.to_vec()).unwrap().split_inclusive("\r\n").map(String::from).collect()
    }

    /// Checksums from the NMEA 0183 examples everyone quotes (gpsd's
    /// "NMEA Revealed": `$GPGLL,4916.45,N,12311.12,W,225444,A*31`) and a
    /// heading sentence checked with an independent XOR by hand.
    #[test]
    fn checksums_match_published_sentences() {
        assert_eq!(checksum(b"GPGLL,4916.45,N,12311.12,W,225444,A"), 0x31);
        assert_eq!(checksum(b"GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,"), 0x47);
    }

    #[test]
    fn an_ok_heading_is_sent_in_all_three_sentences() {
        // True 123.44° with 5.2° E declination: magnetic 118.24 → 118.2.
        let s = sample(Some(123.44), Some(0.734), Integrity::Ok);
        let l = lines(&sentences(&s, 5.2f32.to_radians()));
        assert_eq!(l.len(), 3);
        assert!(l[0].starts_with("$HCHDG,118.2,0.0,E,5.2,E*"), "{}", l[0]);
        assert!(l[1].starts_with("$HCHDT,123.4,T*"), "{}", l[1]);
        assert!(l[2].starts_with("$PMAGI,0.73,ok*"), "{}", l[2]);
        for line in &l {
            assert!(line.ends_with("\r\n") && line.len() <= MAX_SENTENCE_LEN);
            let (body, sum) = line[1..line.len() - 2].split_once('*').unwrap();
            assert_eq!(u8::from_str_radix(sum, 16).unwrap(), checksum(body.as_bytes()));
            assert_eq!(sum, sum.to_uppercase());
        }
    }

    #[test]
    fn a_heading_that_is_not_ok_is_sent_empty_with_its_reason() {
        let s = sample(Some(10.0), Some(3.0), Integrity::Disturbed);
        let l = lines(&sentences(&s, -3.46f32.to_radians()));
        assert!(l[0].starts_with("$HCHDG,,0.0,E,3.5,W*"), "{}", l[0]);
        assert!(l[1].starts_with("$HCHDT,,T*"), "{}", l[1]);
        assert!(l[2].starts_with("$PMAGI,3.00,disturbed*"), "{}", l[2]);
        let none = sample(None, None, Integrity::NoAttitude);
        let l = lines(&sentences(&none, 0.0));
        assert!(l[1].starts_with("$HCHDT,,T*"));
        assert!(l[2].starts_with("$PMAGI,,no_attitude*"), "{}", l[2]);
    }

    #[test]
    fn headings_wrap_and_round_to_a_tenth() {
        // Magnetic = true − declination wraps below 0; 359.96 rounds to 0.0.
        let l = lines(&sentences(&sample(Some(2.0), Some(1.0), Integrity::Ok), 5.0f32.to_radians()));
        assert!(l[0].starts_with("$HCHDG,357.0,"), "{}", l[0]);
        let l = lines(&sentences(&sample(Some(359.96), Some(1.0), Integrity::Ok), 0.0));
        assert!(l[1].starts_with("$HCHDT,0.0,T"), "{}", l[1]);
        let l = lines(&sentences(&sample(Some(0.04), Some(0.005), Integrity::Ok), 0.0));
        assert!(l[1].starts_with("$HCHDT,0.0,T"), "{}", l[1]);
        assert!(l[2].starts_with("$PMAGI,0.01,ok"), "{}", l[2]);
    }

    #[test]
    fn non_finite_or_huge_values_give_empty_fields_not_panics() {
        for v in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, f32::MAX, -1.0, 1.0e7] {
            let s = Sample { heading_rad: Some(v), heading_sigma_deg: Some(v), ..sample(None, None, Integrity::Ok) };
            let b = sentences(&s, v);
            assert!(b.len() <= 3 * MAX_SENTENCE_LEN);
            assert_eq!(lines(&b).len(), 3, "{v}");
        }
    }
}
