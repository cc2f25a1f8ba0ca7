//! The store on a datasheet model of the F405's flash ([`F405Flash`]):
//! power cuts at every byte of erase and program, in any order of erase
//! completion, half-programmed bytes, during the very first save, repeated
//! cuts, read errors during load; and the watchdog during a save, with the
//! firmware's layout and with the layout it had before.

use super::f405_flash::{F405Flash, FlashFault, Timing};
use super::*;
use crate::layout;

/// The firmware's store sectors (1 and 2) on a model of sectors 0..=3.
fn store(f: F405Flash) -> Store<F405Flash> {
    let [a, b] = layout::STORE_OFFSETS;
    Store::new(f, a, b, layout::STORE_SECTOR_BYTES).unwrap()
}

fn chip(seed: u64) -> F405Flash {
    F405Flash::first_sectors(4, seed)
}

/// What a power-up finds.
fn after_power_up(f: &F405Flash, seed: u64) -> Option<Vec<u8>> {
    let mut s = store(f.powered_again(seed));
    s.load().expect("no read errors injected").map(|r| r.payload.to_vec())
}

#[test]
fn save_and_load_round_trip_with_growing_sequence() {
    let mut s = store(chip(1));
    assert_eq!(s.load(), Ok(None));
    assert_eq!(s.save(b"first").unwrap(), 1);
    assert_eq!(s.save(b"second set").unwrap(), 2);
    assert_eq!(s.save(b"third").unwrap(), 3);
    let r = s.load().unwrap().unwrap();
    assert_eq!((r.seq, r.payload.as_slice()), (3, &b"third"[..]));
    // Alternates sectors: the previous record is still there, intact.
    let f = s.release();
    let mut s = store(f);
    assert_eq!(s.read_sector(1 - r.sector).unwrap().unwrap().payload.as_slice(), b"second set");
    // Nothing outside the two store sectors was touched (sector 0 holds the
    // vector table, sector 3 the program).
    let cells = s.release();
    assert!(cells.cells()[..0x4000].iter().chain(&cells.cells()[0xC000..]).all(|&b| b == 0xFF));
}

/// Cuts the power at operation `cut` of a save of `new` onto `before`;
/// returns what the next power-up loads.
fn cut_save(before: &F405Flash, new: &[u8], cut: usize, seed: u64) -> (Result<u32, StoreError>, Option<Vec<u8>>) {
    let mut f = before.powered_again(seed);
    f.cut_after = Some(cut);
    let mut s = store(f);
    let result = s.save(new);
    let f = s.release();
    (result, after_power_up(&f, seed ^ 0xABCD))
}

fn ops_of_a_save(before: &F405Flash, new: &[u8]) -> usize {
    let mut s = store(before.powered_again(7));
    s.save(new).unwrap();
    s.release().ops
}

#[test]
fn a_power_cut_at_every_byte_of_erase_and_program_leaves_the_old_or_the_new_set() {
    // Two saves in, then a third cut at every byte operation (16 KiB of
    // erase in a seeded random order, then the record byte by byte).
    let mut base = store(chip(3));
    base.save(b"old coefficients v1").unwrap();
    base.save(b"old coefficients v2").unwrap();
    let flash = base.release();
    let total = ops_of_a_save(&flash, b"NEW coefficients!");
    assert!(total > 16 * 1024, "a save erases a whole sector and writes a record: {total}");
    let (mut old, mut new) = (0, 0);
    for cut in 0..=total {
        let (result, loaded) = cut_save(&flash, b"NEW coefficients!", cut, cut as u64);
        assert_eq!(result.is_ok(), cut >= total, "cut at {cut}");
        match loaded.as_deref() {
            Some(b"old coefficients v2") => old += 1,
            Some(b"NEW coefficients!") => new += 1,
            other => panic!("cut at {cut}: a mix, an older set or nothing: {other:?}"),
        }
    }
    // The new set appears only once the commit slot is programmed whole.
    assert_eq!(new, 1);
    assert_eq!(old, total);
}

#[test]
fn a_power_cut_during_the_very_first_save_leaves_nothing_or_the_new_set() {
    let blank = chip(5);
    let total = ops_of_a_save(&blank, b"first ever");
    // Every byte of the program phase, and the erase at a stride (the erase
    // of a blank sector changes nothing).
    let cuts = (0..total).filter(|c| *c >= 16 * 1024 || c % 61 == 0).chain([total]);
    for cut in cuts {
        let (result, loaded) = cut_save(&blank, b"first ever", cut, 11 + cut as u64);
        assert_eq!(result.is_ok(), cut >= total);
        match loaded.as_deref() {
            None => assert!(cut < total),
            Some(b"first ever") => assert!(cut >= total - 8, "committed before the slot at {cut}"),
            other => panic!("cut at {cut}: {other:?}"),
        }
    }
}

#[test]
fn repeated_cuts_then_a_clean_save() {
    // Power fails again and again during the retries of one save (different
    // points, different erase orders); each power-up finds the old set, and
    // the save that finally completes gives the new one.
    let mut base = store(chip(9));
    base.save(b"old").unwrap();
    base.save(b"older is gone, this is old").unwrap();
    let mut flash = base.release();
    for (i, cut) in [5usize, 16_383, 16_384 + 3, 9_000, 16_384 + 20, 1].into_iter().enumerate() {
        let mut f = flash.powered_again(100 + i as u64);
        f.cut_after = Some(cut);
        let mut s = store(f);
        assert!(s.save(b"the new set").is_err());
        flash = s.release();
        assert_eq!(after_power_up(&flash, i as u64).as_deref(), Some(&b"older is gone, this is old"[..]), "after cut {i}");
    }
    let mut s = store(flash.powered_again(77));
    s.save(b"the new set").unwrap();
    assert_eq!(after_power_up(&s.release(), 1).as_deref(), Some(&b"the new set"[..]));
}

#[test]
fn a_read_error_during_load_refuses_the_save_and_erases_nothing() {
    let mut base = store(chip(13));
    base.save(b"set A").unwrap();
    base.save(b"set B, the newest").unwrap();
    let flash = base.release();
    for failing in 0..4 {
        // Reads 0..3 are the two sectors' headers and bodies in load().
        let mut f = flash.powered_again(1);
        f.failing_reads = vec![failing];
        let mut s = store(f);
        assert_eq!(s.save(b"set C"), Err(StoreError::Flash), "read {failing} failed");
        let f = s.release();
        assert_eq!(f.cells(), flash.cells(), "nothing was erased or written");
        assert_eq!(after_power_up(&f, 2).as_deref(), Some(&b"set B, the newest"[..]));
    }
    // load() itself says it could not read, rather than "no record".
    let mut f = flash.powered_again(1);
    f.failing_reads = vec![0];
    assert_eq!(store(f).load(), Err(StoreError::Flash));
}

#[test]
fn corrupted_records_are_ignored() {
    let mut s = store(chip(17));
    s.save(b"good").unwrap();
    s.save(b"newer").unwrap();
    let mut f = s.release();
    // Flip one payload bit of the newest record (the second store sector).
    let at = (layout::STORE_OFFSETS[1]) as usize + HEADER;
    f.cells_mut()[at] ^= 0x01;
    let mut s = store(f);
    assert_eq!(s.load().unwrap().unwrap().payload.as_slice(), b"good");
}

#[test]
fn a_save_survives_the_watchdog_with_the_firmware_layout_and_not_with_the_old_one() {
    // The firmware: 16 KiB sectors 1-2, watchdog fed before the save, its
    // timeout the shortest the LSI can make it; every duration at its
    // datasheet maximum.
    let mut f = chip(21);
    f.timing = Timing::Worst;
    f.watchdog_us = Some(u64::from(layout::watchdog_min_timeout_ms()) * 1000);
    let mut s = store(f);
    for payload in [&b"one"[..], &[0x5Au8; MAX_PAYLOAD][..]] {
        s.flash.feed();
        s.save(payload).unwrap();
    }
    let f = s.release();
    assert!(!f.watchdog_fired);
    // The longest stall is one 16 KiB erase: 800 ms, under half the 1 702 ms.
    assert_eq!(f.longest_stall_us, 800_000);
    assert!(2 * f.longest_stall_us < u64::from(layout::watchdog_min_timeout_ms()) * 1000);

    // The layout before: sectors 10 and 11 (128 KiB) and a 500 ms watchdog.
    // Even a typical 2 s erase outlasts it: the board would reset mid-save.
    let mut f = F405Flash::new(22);
    f.watchdog_us = Some(500_000);
    let mut s = Store::new(f, 0x000C_0000, 0x000E_0000, 0x0002_0000).unwrap();
    s.flash.feed();
    assert_eq!(s.save(b"one"), Err(StoreError::Flash));
    let f = s.release();
    assert!(f.watchdog_fired);
    assert_eq!(f.longest_stall_us, 2_000_000);
    assert_eq!(f.powered_again(1).erase(0x4000, 0x4001), Err(FlashFault::Range), "part of a sector cannot be erased");
}

#[test]
fn bad_layouts_and_oversized_payloads_are_refused() {
    assert_eq!(Store::new(chip(1), 10, 0x8000, 0x4000).err(), Some(StoreError::Layout));
    assert_eq!(Store::new(chip(1), 0x4000, 0x4000, 0x4000).err(), Some(StoreError::Layout));
    assert_eq!(Store::new(chip(1), 0x4000, 0x10000, 0x4000).err(), Some(StoreError::Layout), "beyond the flash");
    let mut s = store(chip(1));
    assert_eq!(s.save(&[0u8; MAX_PAYLOAD + 1]), Err(StoreError::TooLarge));
}

#[test]
fn ram_flash_behaves_like_nor() {
    let mut s = Store::new(RamFlash::<4096, 1024>::new(), 0, 2048, 1024).unwrap();
    s.save(b"abc").unwrap();
    s.save(b"defg").unwrap();
    assert_eq!(s.load().unwrap().unwrap().payload.as_slice(), b"defg");
}

mod arbitrary_flash {
    use super::super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn any_flash_image_loads_or_not_but_never_panics(image in proptest::collection::vec(any::<u8>(), 2048)) {
            let mut flash = RamFlash::<2048, 1024>::new();
            let _ = flash.write(0, &image);
            let mut s = Store::new(flash, 0, 1024, 1024).unwrap();
            if let Ok(Some(r)) = s.load() {
                let _ = crate::device::decode_coefficients(&r.payload, r.version);
            }
            prop_assert!(s.save(b"x").is_ok());
            let back = s.load().unwrap().unwrap();
            prop_assert_eq!(back.payload.as_slice(), &b"x"[..]);
        }
    }
}

#[test]
fn a_record_of_the_previous_version_still_loads_and_the_next_save_upgrades_it() {
    // A board that last saved with record version 1 (protocol-2
    // coefficients: bias, matrix, swing, declination, field as f32 LE).
    let fields: [f32; 19] = [1000.0, -2000.0, 500.0, 0.028, 0.0, 0.0, 0.0, 0.028, 0.0, 0.0, 0.0, 0.028, 0.01, 0.0, 0.0, 0.0, 0.002, 0.09, 48_730.0];
    let v1: Vec<u8> = fields.iter().flat_map(|x| x.to_le_bytes()).collect();
    let mut s = store(chip(11));
    assert_eq!(s.save_version(&v1, 1).unwrap(), 1);
    let f = s.release();
    let mut s = store(f.powered_again(12));
    let r = s.load().unwrap().unwrap();
    assert_eq!((r.seq, r.version), (1, 1));
    let (c, cal) = crate::device::decode_coefficients(&r.payload, r.version).expect("the old set loads");
    assert_eq!((c.bias, c.field_nt), ([1000.0, -2000.0, 500.0], 48_730.0));
    assert!(cal.env.is_none(), "no current or temperature terms");
    // The next save writes the current version next to it; the old record
    // stays readable in the other sector until that save is complete.
    let mut c2 = c;
    c2.temp_gain_per_c = [-0.003; 3];
    let mut buf = [0u8; MAX_PAYLOAD];
    let n = crate::device::encode_coefficients(&c2, &mut buf).unwrap();
    assert_eq!(s.save(&buf[..n]).unwrap(), 2);
    let r = s.load().unwrap().unwrap();
    assert_eq!((r.seq, r.version), (2, VERSION));
    assert_eq!(crate::device::decode_coefficients(&r.payload, r.version).unwrap().0, c2);
    // A record of a version this firmware does not know is no record.
    let mut s = store(chip(13));
    s.save_version(b"future", VERSION + 1).unwrap_err();
    assert_eq!(s.load(), Ok(None));
}
