//! The coefficient store under arbitrary input, two ways:
//!
//! * arbitrary flash contents (a RAM flash): the store finds a record or
//!   none, what it returns decodes to coefficients that pass validation or
//!   is refused, and a save after the garbage loads back;
//! * a power cut at a fuzzer-chosen byte operation of a save, on the
//!   datasheet model of the F405's flash (`firmware::store::f405_flash`,
//!   the unit tests' double, feature `mock-flash`: erase in a seeded random
//!   order, half-programmed bytes), with fuzzer-chosen old and new payloads:
//!   the next power-up loads the old set or the new one, never a mix,
//!   nothing or an error; the new one only if the save got to its commit
//!   slot; and a save after the cut completes.
//!
//! The `coefficient_record` fuzz target's body, a plain function: libFuzzer calls it
//! through `coefficient_record.rs`, and `cargo xtask test` replays every seed and
//! corpus input through it (`xtask/src/fuzz.rs`, `replay`).
use embedded_storage::nor_flash::NorFlash;
use firmware::device::decode_coefficients;
use firmware::layout;
use firmware::store::f405_flash::F405Flash;
use firmware::store::{RamFlash, Store, MAX_PAYLOAD};

/// Runs one input.
pub fn drive(data: &[u8]) {
    arbitrary_image(data);
    power_cut(data);
}

fn arbitrary_image(data: &[u8]) {
    let mut flash = RamFlash::<2048, 1024>::new();
    let n = data.len().min(2048);
    let _ = flash.write(0, &data[..n]);
    let Ok(mut store) = Store::new(flash, 0, 1024, 1024) else { return };
    if let Ok(Some(record)) = store.load() {
        if let Some((c, cal)) = decode_coefficients(&record.payload, record.version) {
            assert!(firmware::device::validate(&c).is_ok());
            assert!(cal.field.bias.iter().all(|v| v.is_finite()));
        }
    }
    // A save after garbage still produces a loadable record.
    if store.save(b"payload").is_ok() {
        assert_eq!(store.load().ok().flatten().map(|r| r.payload.to_vec()), Some(b"payload".to_vec()));
    }
}

/// The firmware's store sectors (1 and 2) on a model of sectors 0..=3.
fn store(flash: F405Flash) -> Store<F405Flash> {
    let [a, b] = layout::STORE_OFFSETS;
    match Store::new(flash, a, b, layout::STORE_SECTOR_BYTES) {
        Ok(s) => s,
        Err(e) => panic!("the firmware's layout is refused: {e:?}"),
    }
}

/// What a power-up finds.
fn loaded_after_power_up(flash: &F405Flash, seed: u64) -> Option<Vec<u8>> {
    match store(flash.powered_again(seed)).load() {
        Ok(r) => r.map(|r| r.payload.to_vec()),
        Err(e) => panic!("no read error was injected, yet: {e:?}"),
    }
}

/// Input: cut selector (4 bytes: its low bit picks anywhere or the program
/// phase), seed (1), old payload's length (1),
/// whether an older set sits in the other sector (1), then the payloads.
fn power_cut(data: &[u8]) {
    let Some((head, rest)) = data.split_first_chunk::<7>() else { return };
    let cut_selector = u32::from_le_bytes([head[0], head[1], head[2], head[3]]) as usize;
    let seed = u64::from(head[4]) + 1;
    let old_len = usize::from(head[5]).min(MAX_PAYLOAD).min(rest.len());
    let (old, new) = rest.split_at(old_len);
    let new = &new[..new.len().min(MAX_PAYLOAD)];

    let mut before = store(F405Flash::first_sectors(4, seed));
    if head[6] & 1 == 1 {
        before.save(b"an older set").expect("a clean save");
    }
    before.save(old).expect("a clean save");
    let before = before.release();
    // How many byte operations a whole save of `new` takes from here.
    let mut clean = store(before.powered_again(seed ^ 0x55));
    clean.save(new).expect("a clean save");
    let total = clean.release().ops;

    // Half the inputs cut anywhere (mostly in the 16 KiB erase), half in
    // the program phase (the record's bytes and the commit slot).
    let program_ops = total.saturating_sub(layout::STORE_SECTOR_BYTES as usize);
    let cut = if cut_selector & 1 == 0 { (cut_selector >> 1) % (total + 1) } else { total - (cut_selector >> 1) % (program_ops + 1) };
    let mut flash = before.powered_again(seed ^ 0xAA);
    flash.cut_after = Some(cut);
    let mut s = store(flash);
    let result = s.save(new);
    assert_eq!(result.is_ok(), cut >= total, "cut at {cut} of {total}");
    let after = s.release();
    let loaded = loaded_after_power_up(&after, seed ^ 0x0F);
    assert!(
        loaded.as_deref() == Some(old) || loaded.as_deref() == Some(new),
        "cut at {cut} of {total}: loaded {loaded:?}, neither the old {old:?} nor the new {new:?}"
    );
    // The new set appears only once its commit slot (the last 8 byte
    // operations) is being programmed.
    if loaded.as_deref() != Some(old) {
        assert!(cut + 8 >= total, "the new set before its commit slot: cut at {cut} of {total}");
    }
    // And the board recovers: the next save completes and loads.
    let mut s = store(after.powered_again(seed ^ 0xF0));
    s.save(new).expect("a save after the power cut");
    assert_eq!(loaded_after_power_up(&s.release(), seed).as_deref(), Some(new));
}
