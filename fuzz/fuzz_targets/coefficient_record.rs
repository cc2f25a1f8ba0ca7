//! Arbitrary flash contents: the store finds a record or none, and what it
//! returns decodes to coefficients that pass validation or is refused.
#![no_main]
use firmware::device::decode_coefficients;
use firmware::store::{RamFlash, Store};
use embedded_storage::nor_flash::NorFlash;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
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
});
