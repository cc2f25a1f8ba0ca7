//! Hostile cases: files (issue 37, "one way out" and the output side of
//! "bounded by construction"). Every file a command writes goes through
//! `host_tools::files`: checked against every input before the work,
//! written to a temporary and renamed, keeping the old file's mode; an old
//! file is never lost on a failure.

use std::path::{Path, PathBuf};
use std::process::Output;

use crate::{magcal, p};

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// A file's permission bits.
#[cfg(unix)]
fn mode(path: &Path) -> u32 {
    use std::os::unix::fs::PermissionsExt;
    std::fs::metadata(path).unwrap().permissions().mode() & 0o7777
}

#[cfg(unix)]
fn set_mode(path: &Path, mode: u32) {
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(mode)).unwrap();
}

/// The names in `dir` that are temporaries (`.magcal-…`).
fn temporaries(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).filter(|n| n.starts_with(".magcal-")).collect()
}

/// A simulated swing test (seed 1: 6 650 rows, 857 kB, with its
/// `true_heading_deg`) written by `magcal simulate` into `dir/name`.
fn swing(dir: &Path, name: &str) -> PathBuf {
    let path = dir.join(name);
    let out = magcal(&["simulate", "swing", "--out", p(&path)]);
    assert!(out.status.success(), "{}", stderr(&out));
    path
}

/// A field calibration of that swing (`fit` at the simulator's intensity).
fn calibration(dir: &Path, rec: &Path) -> PathBuf {
    let cal = dir.join("cal.json");
    let out = magcal(&["fit", "--input", p(rec), "--field-nt", "48000", "--out", p(&cal)]);
    assert!(out.status.success(), "{}", stderr(&out));
    cal
}

/// `magcal log --force` on a port that does not open: the existing log
/// (857 kB) was deleted, and through a symbolic link its target truncated
/// to 0 bytes (the file was created before the port opened and the
/// clean-up removed any output of 30 bytes or less). Now the old log stays
/// as it was, byte for byte, and nothing else is left.
#[test]
fn log_force_on_a_port_that_does_not_open_keeps_the_old_log() {
    let dir = tempfile::tempdir().unwrap();
    let old = swing(dir.path(), "board_log.csv");
    let before = std::fs::read(&old).unwrap();
    assert!(before.len() > 800_000);
    let out = magcal(&["log", "--port", "/nonexistent", "--out", p(&old), "--force"]);
    assert!(!out.status.success() && stderr(&out).contains("cannot open serial port /nonexistent"), "{}", stderr(&out));
    assert!(std::fs::read(&old).unwrap() == before, "the old log is kept whole");
    #[cfg(unix)]
    {
        let link = dir.path().join("link.csv");
        std::os::unix::fs::symlink(&old, &link).unwrap();
        let out = magcal(&["log", "--port", "/nonexistent", "--out", p(&link), "--force"]);
        assert!(!out.status.success(), "{}", stderr(&out));
        assert!(std::fs::read(&old).unwrap() == before, "the link's target is kept whole");
        assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
    }
    assert!(temporaries(dir.path()).is_empty(), "{:?}", temporaries(dir.path()));
}

/// `report --validation rep/deviation_card.csv --out rep`: exit 0 and the
/// recording replaced by the card. Every file of the report's folder is
/// checked against every input before the work.
#[test]
fn report_refuses_an_input_among_the_files_it_writes() {
    let dir = tempfile::tempdir().unwrap();
    let rep = dir.path().join("rep");
    std::fs::create_dir(&rep).unwrap();
    let rec = swing(&rep, "deviation_card.csv");
    let cal = calibration(dir.path(), &rec);
    let before = std::fs::read(&rec).unwrap();
    let out = magcal(&["report", "--validation", p(&rec), "--cal", p(&cal), "--out", p(&rep)]);
    let err = stderr(&out);
    assert!(!out.status.success(), "{err}");
    assert!(err.contains("deviation_card.csv is the input") && err.contains("--out"), "{err}");
    assert!(std::fs::read(&rec).unwrap() == before, "the recording is kept");
    assert!(!rep.join("index.html").exists(), "refused before the work");
    // A document reached through a link under the page's name: the same.
    #[cfg(unix)]
    {
        let rep2 = dir.path().join("rep2");
        std::fs::create_dir(&rep2).unwrap();
        std::os::unix::fs::symlink(&cal, rep2.join("index.html")).unwrap();
        let doc = std::fs::read(&cal).unwrap();
        let rec2 = swing(dir.path(), "validation.csv");
        let out = magcal(&["report", "--validation", p(&rec2), "--cal", p(&cal), "--out", p(&rep2)]);
        assert!(!out.status.success() && stderr(&out).contains("index.html is the input"), "{}", stderr(&out));
        assert!(std::fs::read(&cal).unwrap() == doc);
    }
    // Elsewhere, the report is written.
    let fine = dir.path().join("fine");
    let out = magcal(&["report", "--validation", p(&rec), "--cal", p(&cal), "--out", p(&fine)]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(fine.join("index.html").is_file() && fine.join("deviation_card.csv").is_file());
}

/// `simulate swing --out x.csv` when `x.truth.json` is a directory or a
/// FIFO: `x.csv` was replaced by the new run, then the command failed on
/// the truth — a recording left without its truth. Both targets are now
/// checked before the work and renamed only when both are written.
#[test]
fn simulate_keeps_the_old_recording_when_its_truth_cannot_be_written() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("x.csv");
    std::fs::write(&csv, "old recording\n").unwrap();
    let truth = dir.path().join("x.truth.json");
    std::fs::create_dir(&truth).unwrap();
    let out = magcal(&["simulate", "swing", "--out", p(&csv)]);
    let err = stderr(&out);
    assert!(!out.status.success() && err.contains("x.truth.json: is a directory"), "{err}");
    assert!(std::fs::read_to_string(&csv).unwrap() == "old recording\n", "the old recording is replaced");
    #[cfg(unix)]
    {
        std::fs::remove_dir(&truth).unwrap();
        let status = std::process::Command::new("mkfifo").arg(&truth).status().unwrap();
        assert!(status.success());
        let out = magcal(&["simulate", "swing", "--out", p(&csv)]);
        let err = stderr(&out);
        assert!(!out.status.success() && err.contains("x.truth.json: is a named pipe"), "{err}");
        assert!(std::fs::read_to_string(&csv).unwrap() == "old recording\n", "the old recording is replaced");
        std::fs::remove_file(&truth).unwrap();
    }
    assert!(temporaries(dir.path()).is_empty(), "{:?}", temporaries(dir.path()));
    // Both free: both written.
    let out = magcal(&["simulate", "swing", "--out", p(&csv)]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(std::fs::metadata(&csv).unwrap().len() > 800_000 && truth.is_file());
    assert!(temporaries(dir.path()).is_empty(), "{:?}", temporaries(dir.path()));
}

/// Every replaced output became 0600 (a 0644 file shared with a team lost
/// its readers) and a 0444 file was replaced without a word. A replaced
/// file keeps its mode; a new one gets 0666 less the umask; a read-only
/// one is refused before the work and kept.
#[cfg(unix)]
#[test]
fn a_replaced_output_keeps_its_mode_and_a_read_only_one_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let shared = swing(dir.path(), "shared.csv");
    // New files: the default mode (magcal runs with the test's umask,
    // read without changing it from /proc; 022 where not shown).
    let umask = std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| s.lines().find_map(|l| l.strip_prefix("Umask:").and_then(|v| u32::from_str_radix(v.trim(), 8).ok())))
        .unwrap_or(0o022);
    assert_eq!(mode(&shared), 0o666 & !umask, "a new recording");
    assert_eq!(mode(&shared.with_extension("truth.json")), 0o666 & !umask, "a new truth");
    set_mode(&shared, 0o644);
    set_mode(&shared.with_extension("truth.json"), 0o640);
    let out = magcal(&["simulate", "swing", "--seed", "2", "--out", p(&shared)]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(mode(&shared), 0o644);
    assert_eq!(mode(&shared.with_extension("truth.json")), 0o640);

    let kept = dir.path().join("kept.csv");
    std::fs::write(&kept, "precious\n").unwrap();
    set_mode(&kept, 0o444);
    let out = magcal(&["simulate", "swing", "--out", p(&kept)]);
    let err = stderr(&out);
    assert!(!out.status.success() && err.contains("kept.csv: is read-only (mode 0444)"), "{err}");
    assert_eq!(std::fs::read_to_string(&kept).unwrap(), "precious\n");
    assert_eq!(mode(&kept), 0o444);
    assert!(temporaries(dir.path()).is_empty(), "{:?}", temporaries(dir.path()));
}

/// A read-only output folder failed only after the work, naming the
/// temporary file. It is refused before the work, naming the output. The
/// tests run as root, for whom a 0555 folder is writable: sysfs refuses
/// new files to root too, so `/sys` stands for a read-only folder (a
/// 0555 folder is tried as well where permission bits bind this user).
#[cfg(target_os = "linux")]
#[test]
fn a_folder_that_cannot_be_written_is_refused_before_the_work() {
    let out = magcal(&["simulate", "swing", "--out", "/sys/x.csv"]);
    let err = stderr(&out);
    assert!(!out.status.success(), "{err}");
    assert!(err.contains("/sys/x.csv: the folder /sys cannot be written") && !err.contains(".magcal-"), "{err}");
    let dir = tempfile::tempdir().unwrap();
    let locked = dir.path().join("locked");
    std::fs::create_dir(&locked).unwrap();
    set_mode(&locked, 0o555);
    let binds = std::fs::write(locked.join("probe"), "").is_err();
    if binds {
        let out = magcal(&["card", "--input", "x.csv", "--cal", "c.json", "--csv", p(&locked.join("card.csv"))]);
        let err = stderr(&out);
        assert!(!out.status.success() && err.contains("card.csv: the folder") && err.contains("cannot be written"), "{err}");
    }
    set_mode(&locked, 0o755);
}
