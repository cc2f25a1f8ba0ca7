#![allow(clippy::unwrap_used, clippy::indexing_slicing)]
use super::converter::{ccitt, div_ceil_u64_u32, div_u64_u32, ADS_FRAME_BYTES};
use super::*;
use embedded_hal::digital::{InputPin, OutputPin};
use embedded_hal::spi::{Operation, SpiDevice};

/// A NULL frame, and the channel-0 code and STATUS the model answers.
fn null_frame(adc: &mut Ads131m04Model) -> (u16, i32) {
    let tx = [0u8; ADS_FRAME_BYTES];
    let mut rx = [0u8; ADS_FRAME_BYTES];
    adc.transaction(&mut [Operation::Transfer(&mut rx, &tx)]).unwrap();
    let status = u16::from_be_bytes([rx[0], rx[1]]);
    let ch0 = i32::from_be_bytes([rx[3], rx[4], rx[5], 0]) >> 8;
    (status, ch0)
}

/// WREG CLOCK = channels 0-2 on, OSR 128, high resolution.
fn configure_osr128(adc: &mut Ads131m04Model) {
    let mut tx = [0u8; ADS_FRAME_BYTES];
    tx[..2].copy_from_slice(&(0x6000u16 | (3 << 7)).to_be_bytes());
    tx[3..5].copy_from_slice(&0x0702u16.to_be_bytes());
    let mut rx = [0u8; ADS_FRAME_BYTES];
    adc.transaction(&mut [Operation::Transfer(&mut rx, &tx)]).unwrap();
}

#[test]
fn crc_is_the_official_ccitt_check_value() {
    // CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF) of "123456789" is 0x29B1.
    assert_eq!(ccitt(b"123456789"), 0x29B1);
}

#[test]
fn conversions_come_at_osr_over_half_clkin() {
    static S: BridgeModel = BridgeModel::new();
    let mut adc = Ads131m04Model::new(&S);
    // Power-on OSR 1024 at 8 MHz CLKIN: 1024 / 4 MHz = 256 µs.
    assert_eq!(S.conversion_period_ns(), 256_000);
    configure_osr128(&mut adc);
    // OSR 128: 32 µs (31.25 kSPS; 32 kSPS with the datasheet's 8.192 MHz).
    assert_eq!(S.conversion_period_ns(), 32_000);
    let mut drdy = DrdyPinModel::new(&S);
    let t0 = S.now_ns();
    for _ in 0..10 {
        crate::acquisition::run_ready(embedded_hal_async::digital::Wait::wait_for_low(&mut drdy)).unwrap().unwrap();
        null_frame(&mut adc);
    }
    // The CLOCK write restarted the grid mid-frame; ten conversions later
    // the clock stands just past the tenth, plus the last frame's 6.9 µs.
    let elapsed = S.now_ns() - t0;
    assert!((320_000..=330_000).contains(&elapsed), "{elapsed} ns");
}

#[test]
fn a_flip_halfway_through_the_middle_period_gives_the_offset() {
    // The sinc³ weights are symmetric: a conversion whose 3-period window
    // is split at 1.5 periods sees equal weights of both polarities.
    static S: BridgeModel = BridgeModel::new();
    let mut adc = Ads131m04Model::new(&S);
    configure_osr128(&mut adc);
    S.set_truth([10_000.0, 0.0, 0.0], [5_000.0, 0.0, 0.0]);
    S.advance_ns(10 * 32_000 - S.now_ns() % 32_000); // on a conversion edge
    S.advance_ns(16_000); // half a period in: flip to RESET
    StrapPinModel::reset(&S).set_high().unwrap();
    let mut drdy = DrdyPinModel::new(&S);
    let mut codes = Vec::new();
    // Drain, then the conversions ending 0.5, 1.5, 2.5, 3.5 periods after.
    while drdy.is_low().unwrap() {
        null_frame(&mut adc);
    }
    for _ in 0..4 {
        crate::acquisition::run_ready(embedded_hal_async::digital::Wait::wait_for_low(&mut drdy)).unwrap().unwrap();
        codes.push(null_frame(&mut adc).1);
    }
    let h = 10_000.0 * model_codes_per_nt();
    // Window split at 2.5: F₃(2.5) = 1 − 0.5³/6; at 1.5: ½; at 0.5: 0.5³/6.
    let want = |f: f64| (5_000.0 + h * (f - (1.0 - f))).round() as i32;
    assert_eq!(codes[0], want(1.0 - 0.125 / 6.0));
    assert_eq!(codes[1], 5_000);
    assert_eq!(codes[2], want(0.125 / 6.0));
    assert_eq!(codes[3], want(0.0));
}

#[test]
fn unread_conversions_are_buffered_two_deep() {
    static S: BridgeModel = BridgeModel::new();
    let mut adc = Ads131m04Model::new(&S);
    configure_osr128(&mut adc);
    S.set_truth([1_000.0, 0.0, 0.0], [0.0; 3]);
    // A pause of many periods: the buffer holds the last two conversions.
    S.advance_ns(40 * 32_000);
    // The field steps by 4 000 nT just before the next conversion ends, so
    // the newest conversion differs from the one before it.
    let to_edge = 32_000 - S.now_ns() % 32_000;
    S.advance_ns(to_edge - 1_000);
    S.set_truth([5_000.0, 0.0, 0.0], [0.0; 3]);
    S.advance_ns(1_000);
    let mut drdy = DrdyPinModel::new(&S);
    assert!(drdy.is_low().unwrap());
    let (_, first) = null_frame(&mut adc);
    assert!(drdy.is_low().unwrap(), "one more conversion waits");
    let (status2, second) = null_frame(&mut adc);
    assert!(drdy.is_high().unwrap());
    // The first read after the pause is the older conversion.
    assert_eq!(first, (1_000.0 * model_codes_per_nt()).round() as i32);
    assert!(second > first + 1_000, "{second} vs {first}");
    // The response to a NULL is STATUS one frame late: the frame after the
    // first read says data were waiting then.
    assert_eq!(status2 & 0x000F, 0x000F, "STATUS carries DRDY for the enabled channels");
    // With nothing new, a read returns the last data again; the STATUS of
    // the frame after says nothing was waiting.
    let (_, third) = null_frame(&mut adc);
    let (status4, _) = null_frame(&mut adc);
    assert_eq!((third, status4 & 0x000F), (second, 0));
}

#[test]
fn the_model_divides_times_as_u64_division_does() {
    // Against the language's u64 division (independent of the chunking).
    let mut rng = calib_core::conformance::SplitMix64::new(9);
    for _ in 0..20_000 {
        let a = (rng.uniform() * 1e13) as u64;
        let b = (rng.uniform() * 3e7) as u32 + 1;
        assert_eq!(div_u64_u32(a, b), a / u64::from(b), "{a} / {b}");
        assert_eq!(div_ceil_u64_u32(a, b), a.div_ceil(u64::from(b)), "{a} / {b}");
    }
    assert_eq!(div_u64_u32(u64::MAX, u32::MAX), u64::MAX / u64::from(u32::MAX));
    assert_eq!(div_ceil_u64_u32(7, 0), 7, "a zero divisor counts as 1");
}
