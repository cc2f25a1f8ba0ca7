//! The PGNs read, decoded as canboat's published definitions
//! (`canboat.json`, v6.0.1: field order, bit offset and length, resolution,
//! signedness, range) give them; a value outside the field's range — the
//! "not available" (`0x7FFF`, `0xFFFF`, …), "error" and reserved codes at a
//! field's top — is NaN, never a number.

/// Vessel Heading.
pub const VESSEL_HEADING: u32 = 127_250;
/// Rate of Turn.
pub const RATE_OF_TURN: u32 = 127_251;
/// Attitude.
pub const ATTITUDE: u32 = 127_257;
/// Position, Rapid Update.
pub const POSITION_RAPID: u32 = 129_025;
/// COG & SOG, Rapid Update.
pub const COG_SOG_RAPID: u32 = 129_026;
/// Simnet: Magnetic Field (Navico/Simrad proprietary).
pub const SIMNET_MAGNETIC_FIELD: u32 = 65_350;

/// The PGNs read, with canboat's names.
pub const READ: [(u32, &str); 6] = [
    (VESSEL_HEADING, "Vessel Heading"),
    (RATE_OF_TURN, "Rate of Turn"),
    (ATTITUDE, "Attitude"),
    (POSITION_RAPID, "Position, Rapid Update"),
    (COG_SOG_RAPID, "COG & SOG, Rapid Update"),
    (SIMNET_MAGNETIC_FIELD, "Simnet: Magnetic Field"),
];

/// The PGNs canboat's `canboat.json` (v6.0.1) marks `"Type": "Fast"`: sent
/// as fast packets, so a PLAIN log holds them in frames.
const FAST_PACKET: [u32; 151] = [
    126208, 126464, 126720, 126983, 126984, 126985, 126986, 126987, 126988, 126996, 126998, 127233, 127237, 127489, 127490, 127491, 127494, 127495, 127496,
    127497, 127498, 127503, 127504, 127506, 127507, 127509, 127510, 127511, 127512, 127513, 127514, 128275, 128520, 128538, 129029, 129038, 129039, 129040,
    129041, 129044, 129045, 129284, 129285, 129301, 129302, 129538, 129540, 129541, 129542, 129545, 129547, 129549, 129551, 129556, 129792, 129793, 129794,
    129795, 129796, 129797, 129798, 129799, 129800, 129801, 129802, 129803, 129804, 129805, 129806, 129807, 129808, 129809, 129810, 130052, 130053, 130054,
    130060, 130061, 130064, 130065, 130066, 130067, 130068, 130069, 130070, 130071, 130072, 130073, 130074, 130320, 130321, 130322, 130323, 130324, 130330,
    130561, 130562, 130563, 130564, 130565, 130566, 130567, 130569, 130570, 130571, 130572, 130573, 130574, 130577, 130578, 130580, 130581, 130583, 130584,
    130586, 130816, 130817, 130818, 130819, 130820, 130821, 130822, 130823, 130824, 130825, 130827, 130828, 130831, 130832, 130833, 130834, 130835, 130836,
    130837, 130838, 130839, 130840, 130842, 130843, 130845, 130846, 130847, 130848, 130850, 130851, 130856, 130860, 130880, 130881, 130918, 130944,
];

/// Whether a PGN is sent as fast packets: canboat's list, and the
/// proprietary fast-packet range 130816–131071 of NMEA 2000.
pub fn is_fast_packet(pgn: u32) -> bool {
    FAST_PACKET.binary_search(&pgn).is_ok() || (130_816..=131_071).contains(&pgn)
}

/// A heading's or a course's reference (canboat's `DIRECTION_REFERENCE`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reference {
    /// 0: true.
    True,
    /// 1: magnetic.
    Magnetic,
    /// 2 (error) or 3 (not available).
    Unknown,
}

/// A decoded message of a PGN read (angles in degrees).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Decoded {
    /// 127250.
    Heading {
        /// Heading, degrees (0.0001 rad, unsigned 16 bits at byte 1).
        heading_deg: f64,
        /// Deviation, degrees (signed 16 bits at byte 3).
        deviation_deg: f64,
        /// Variation, degrees east (signed 16 bits at byte 5).
        variation_deg: f64,
        /// Reference (2 bits at byte 7).
        reference: Reference,
    },
    /// 127251: rate of turn, rad/s (3.125e-8 rad/s, signed 32 bits at byte 1).
    RateOfTurn {
        /// Positive turning to starboard.
        rate_rad_s: f64,
    },
    /// 127257: yaw, pitch, roll, degrees (0.0001 rad, signed 16 bits at
    /// bytes 1, 3, 5).
    Attitude {
        /// Yaw.
        yaw_deg: f64,
        /// Pitch.
        pitch_deg: f64,
        /// Roll.
        roll_deg: f64,
    },
    /// 129025: latitude and longitude, degrees (1e-7°, signed 32 bits at
    /// bytes 0 and 4).
    Position {
        /// Latitude.
        lat_deg: f64,
        /// Longitude.
        lon_deg: f64,
    },
    /// 129026.
    CogSog {
        /// COG reference (2 bits at byte 1).
        reference: Reference,
        /// Course over ground, degrees (0.0001 rad, unsigned 16 bits at byte 2).
        cog_deg: f64,
        /// Speed over ground, m/s (0.01 m/s, unsigned 16 bits at byte 4).
        sog_mps: f64,
    },
    /// 65350: the field's three axes, counts (signed 16 bits at bytes 0, 2,
    /// 4: see the module's docs on this PGN).
    Field {
        /// X, Y, Z.
        xyz: [f64; 3],
    },
}

/// The largest raw value of an angle field of 0.0001 rad: canboat's range
/// is ±3.1415926 rad (signed) or 0–6.2831852 rad (unsigned).
const ANGLE_SIGNED_MAX: i64 = 31_415;
const ANGLE_UNSIGNED_MAX: i64 = 62_831;

/// `n` bytes little-endian from `at`, as a signed or unsigned integer.
fn raw(data: &[u8], at: usize, n: usize, signed: bool) -> Option<i64> {
    let bytes = data.get(at..at + n)?;
    let u = bytes.iter().rev().fold(0u64, |acc, &b| (acc << 8) | u64::from(b));
    let bits = 8 * n as u32;
    Some(if signed && u >> (bits - 1) == 1 { u as i64 - (1i64 << bits) } else { u as i64 })
}

/// A field's value: `raw · resolution` when `min ≤ raw ≤ max`, else NaN.
fn value(raw: i64, resolution: f64, min: i64, max: i64) -> f64 {
    if (min..=max).contains(&raw) {
        raw as f64 * resolution
    } else {
        f64::NAN
    }
}

fn angle_deg(data: &[u8], at: usize, signed: bool) -> Option<f64> {
    let r = raw(data, at, 2, signed)?;
    let (min, max) = if signed { (-ANGLE_SIGNED_MAX, ANGLE_SIGNED_MAX) } else { (0, ANGLE_UNSIGNED_MAX) };
    Some(value(r, 1e-4, min, max).to_degrees())
}

fn reference(bits: u8) -> Reference {
    match bits & 0b11 {
        0 => Reference::True,
        1 => Reference::Magnetic,
        _ => Reference::Unknown,
    }
}

/// Decodes a message of a PGN read; `None` for another PGN or a payload too
/// short for its fields (8 bytes: these PGNs are single frames).
pub fn decode(pgn: u32, data: &[u8]) -> Option<Decoded> {
    if data.len() < 8 {
        return None;
    }
    Some(match pgn {
        VESSEL_HEADING => Decoded::Heading {
            heading_deg: angle_deg(data, 1, false)?,
            deviation_deg: angle_deg(data, 3, true)?,
            variation_deg: angle_deg(data, 5, true)?,
            reference: reference(*data.get(7)?),
        },
        // canboat's range: −2147483647 … 2147483644 raw (±67.108863 rad/s).
        RATE_OF_TURN => Decoded::RateOfTurn { rate_rad_s: value(raw(data, 1, 4, true)?, 3.125e-8, -2_147_483_647, 2_147_483_644) },
        ATTITUDE => Decoded::Attitude { yaw_deg: angle_deg(data, 1, true)?, pitch_deg: angle_deg(data, 3, true)?, roll_deg: angle_deg(data, 5, true)? },
        POSITION_RAPID => Decoded::Position {
            lat_deg: value(raw(data, 0, 4, true)?, 1e-7, -900_000_000, 900_000_000),
            lon_deg: value(raw(data, 4, 4, true)?, 1e-7, -1_800_000_000, 1_800_000_000),
        },
        // SOG: 0–655.32 m/s (raw ≤ 65532).
        COG_SOG_RAPID => Decoded::CogSog { reference: reference(*data.get(1)?), cog_deg: angle_deg(data, 2, false)?, sog_mps: value(raw(data, 4, 2, false)?, 0.01, 0, 65_532) },
        // Signed 16 bits; NMEA 2000's top three codes (0x7FFD–0x7FFF:
        // reserved, error, not available) are not values.
        SIMNET_MAGNETIC_FIELD => Decoded::Field { xyz: [0, 2, 4].map(|at| raw(data, at, 2, true).map_or(f64::NAN, |r| value(r, 1.0, -32_768, 32_764))) },
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fast_packet_list_is_sorted() {
        assert!(FAST_PACKET.windows(2).all(|w| w[0] < w[1]));
        assert!(is_fast_packet(129_029) && is_fast_packet(130_842) && is_fast_packet(131_000));
        assert!(!is_fast_packet(127_250) && !is_fast_packet(65_350));
    }

    #[test]
    fn the_triton_lines_decode_by_hand() {
        // 127250 from 27: heading 0xcd71 = 52593 → 5.2593 rad, deviation and
        // variation 0x7fff (not available), reference 0xfd & 3 = 1 magnetic.
        let Some(Decoded::Heading { heading_deg, deviation_deg, variation_deg, reference }) = decode(VESSEL_HEADING, &[0x00, 0x71, 0xcd, 0xff, 0x7f, 0xff, 0x7f, 0xfd]) else { panic!() };
        assert!((heading_deg - 5.2593f64.to_degrees()).abs() < 1e-9 && deviation_deg.is_nan() && variation_deg.is_nan() && reference == Reference::Magnetic);
        // 127250 from 52: variation 0x0097 = 151 → 0.0151 rad, true.
        let Some(Decoded::Heading { variation_deg, reference, .. }) = decode(VESSEL_HEADING, &[0xff, 0xa5, 0xcb, 0xff, 0x7f, 0x97, 0x00, 0xfc]) else { panic!() };
        assert!((variation_deg - 0.0151f64.to_degrees()).abs() < 1e-9 && reference == Reference::True);
        // 127251 from 52: 0xfffb672d = −301267 · 3.125e-8 rad/s.
        let Some(Decoded::RateOfTurn { rate_rad_s }) = decode(RATE_OF_TURN, &[0xff, 0x2d, 0x67, 0xfb, 0xff, 0xff, 0xff, 0xff]) else { panic!() };
        assert!((rate_rad_s + 301_267.0 * 3.125e-8).abs() < 1e-15);
        // 129026: reference 0xfc & 3 = true, COG 0xd0ad, SOG 0x017e = 3.82 m/s.
        let Some(Decoded::CogSog { reference, cog_deg, sog_mps }) = decode(COG_SOG_RAPID, &[0xff, 0xfc, 0xad, 0xd0, 0x7e, 0x01, 0xff, 0xff]) else { panic!() };
        assert!(reference == Reference::True && (cog_deg - 5.3421f64.to_degrees()).abs() < 1e-9 && (sog_mps - 3.82).abs() < 1e-12);
        // 65350: three little-endian int16.
        assert_eq!(decode(SIMNET_MAGNETIC_FIELD, &[0xf9, 0xfd, 0x01, 0xf6, 0xcd, 0x23, 0x02, 0xff]), Some(Decoded::Field { xyz: [-519.0, -2559.0, 9165.0] }));
        // Not available everywhere; a short payload is not decoded.
        let Some(Decoded::Position { lat_deg, lon_deg }) = decode(POSITION_RAPID, &[0xff, 0xff, 0xff, 0x7f, 0xff, 0xff, 0xff, 0x7f]) else { panic!() };
        assert!(lat_deg.is_nan() && lon_deg.is_nan());
        assert_eq!(decode(ATTITUDE, &[0; 7]), None);
        assert_eq!(decode(130_306, &[0; 8]), None);
    }
}
