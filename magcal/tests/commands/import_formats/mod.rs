//! `magcal import` of each vehicle log format against its independent
//! reader (pymavlink, pyulog, rosbags, a decode from canboat's published
//! PGN definitions): counts and values from the reader's output committed
//! beside each fixture with the script that made it.

mod dataflash_gyro;
mod nmea2000;
mod ros2;
mod tlog;
mod ulog;

#[path = "../../../../fuzz/fuzz_targets/import_drive.rs"]
mod import_drive;

/// The `import` fuzz target's seeds (a prefix of each format's fixture) and
/// any crash it saved replay without a panic, and a seed of every format is
/// there.
#[test]
fn every_import_fuzz_input_replays_without_a_panic() {
    use host_tools::data::import::Format;
    let fuzz = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz");
    let mut formats = std::collections::BTreeSet::new();
    for dir in [fuzz.join("seeds/import"), fuzz.join("artifacts/import")] {
        let Ok(entries) = std::fs::read_dir(&dir) else { continue };
        for entry in entries {
            let path = entry.unwrap().path();
            let bytes = std::fs::read(&path).unwrap();
            let outcome = std::panic::catch_unwind(|| import_drive::drive(&bytes));
            assert!(outcome.is_ok(), "{} panics", path.display());
            if let Some(&pick) = bytes.first() {
                formats.insert(Format::ALL[pick as usize % Format::ALL.len()]);
            }
        }
    }
    let missing: Vec<_> = Format::ALL.into_iter().filter(|f| !formats.contains(f)).collect();
    assert!(missing.is_empty(), "fuzz/seeds/import has no seed of {missing:?}");
}
