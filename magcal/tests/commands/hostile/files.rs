//! Hostile cases: files ("one way out" and the output side of
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

/// `card --step-deg 1e-300`: exit 101 (capacity overflow); `1e-7`: an
/// abort allocating 115 GB. The step has a stated range in its parser, and
/// the library's own check bounds the sectors to 3 600.
#[test]
fn card_step_out_of_its_range_is_refused_without_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let rec = swing(dir.path(), "swing.csv");
    let cal = calibration(dir.path(), &rec);
    for step in ["1e-300", "1e-7", "0", "-15", "nan", "inf", "400"] {
        let started = std::time::Instant::now();
        let out = magcal(&["card", "--input", p(&rec), "--cal", p(&cal), "--reference-column", "true_heading_deg", "--step-deg", step]);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(1), "{step}: {err}");
        assert!(err.contains("--step-deg") && err.contains("0.1 … 180 degrees") && !err.contains("panicked"), "{step}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{step}: {err}");
        assert!(started.elapsed().as_secs_f64() < 5.0);
    }
    let out = magcal(&["card", "--input", p(&rec), "--cal", p(&cal), "--reference-column", "true_heading_deg", "--points", "4"]);
    assert!(out.status.code() == Some(1) && stderr(&out).contains("--points") && stderr(&out).contains("8 or 16"), "{}", stderr(&out));
}

/// `card --reference-column mx` took the field's counts as a heading. The
/// reference must be a heading column of the registry (or one the project
/// does not know, a lab's own): `mx` is refused, saying what it holds.
#[test]
fn card_refuses_a_reference_column_that_is_not_a_heading() {
    let dir = tempfile::tempdir().unwrap();
    let rec = swing(dir.path(), "swing.csv");
    let cal = calibration(dir.path(), &rec);
    for (column, what) in [("mx", "the magnetic field"), ("roll_deg", "an attitude or position angle"), ("t", "a time")] {
        let out = magcal(&["card", "--input", p(&rec), "--cal", p(&cal), "--reference-column", column]);
        let err = stderr(&out);
        assert!(!out.status.success() && out.stdout.is_empty(), "{column}: {err}");
        assert!(err.contains(&format!("column `{column}` is {what}")) && err.contains("not a heading") && err.contains("--reference-column"), "{column}: {err}");
    }
    let out = magcal(&["card", "--input", p(&rec), "--cal", p(&cal), "--reference-column", "true_heading_deg"]);
    assert!(out.status.success(), "{}", stderr(&out));
    // The report's truth column is read through the same check.
    let out = magcal(&["report", "--validation", p(&rec), "--cal", p(&cal), "--truth-column", "mx", "--out", p(&dir.path().join("rep"))]);
    assert!(!out.status.success() && stderr(&out).contains("column `mx` is the magnetic field"), "{}", stderr(&out));
}

/// `card --json | head -c 10`: a panic on the closed pipe. A closed stdout
/// ends the command quietly (SIGPIPE, as any Unix tool), with no panic
/// message and no temporary left. The card at 0.5° (720 sectors, some
/// 300 kB of JSON) overfills the pipe's 64 kB, so the write meets the
/// closed pipe whatever the timing.
#[cfg(unix)]
#[test]
fn a_closed_stdout_ends_the_command_quietly() {
    use std::io::Read;
    use std::os::unix::process::ExitStatusExt;
    use std::process::{Command, Stdio};
    let dir = tempfile::tempdir().unwrap();
    let rec = swing(dir.path(), "swing.csv");
    let cal = calibration(dir.path(), &rec);
    let csv = dir.path().join("card.csv");
    let mut child = Command::new(env!("CARGO_BIN_EXE_magcal"))
        .args(["card", "--input", p(&rec), "--cal", p(&cal), "--reference-column", "true_heading_deg", "--step-deg", "0.5", "--json", "--csv", p(&csv)])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut head = [0u8; 10];
    child.stdout.take().unwrap().read_exact(&mut head).unwrap();
    // (The read end is dropped here: the pipe is closed.)
    let out = child.wait_with_output().unwrap();
    let err = stderr(&out);
    assert_eq!(&head[..1], b"{");
    assert!(!err.contains("panicked") && !err.contains("Broken pipe"), "{err}");
    assert!(out.status.success() || out.status.signal() == Some(libc_sigpipe()), "{:?}: {err}", out.status);
    assert!(csv.is_file() && temporaries(dir.path()).is_empty());
}

/// SIGPIPE's number (13 on Linux and the BSDs).
#[cfg(unix)]
fn libc_sigpipe() -> i32 {
    13
}

/// SIGTERM, SIGINT and SIGHUP left `.magcal-*.tmp` files (up to 2 MB)
/// beside the output. A long simulation (400 000 rows, 64 MB) is signalled
/// the moment its temporary appears: the temporary is removed, the old
/// recording is kept, and the status is 128 + the signal.
#[cfg(unix)]
#[test]
fn a_signal_mid_write_leaves_no_temporary_and_the_old_file() {
    use std::process::{Command, Stdio};
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("big.csv");
    std::fs::write(&out, "old recording\n").unwrap();
    for (signal, number) in [("TERM", 15), ("INT", 2), ("HUP", 1), ("TERM", 15)] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_magcal"))
            .args(["simulate", "run", "--leg-m", "100000", "--speed-mps", "2", "--rate-hz", "4", "--out", p(&out)])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let started = std::time::Instant::now();
        while temporaries(dir.path()).is_empty() {
            assert!(started.elapsed().as_secs() < 60, "no temporary appeared");
            assert!(child.try_wait().unwrap().is_none(), "finished before it was signalled");
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
        let kill = Command::new("kill").args([&format!("-{signal}"), &child.id().to_string()]).status().unwrap();
        assert!(kill.success());
        let status = child.wait().unwrap();
        assert_eq!(status.code(), Some(128 + number), "SIG{signal}: {status:?}");
        assert!(temporaries(dir.path()).is_empty(), "SIG{signal}: {:?}", temporaries(dir.path()));
        assert!(std::fs::read_to_string(&out).unwrap() == "old recording\n", "SIG{signal}: the old recording is lost");
    }
}

/// Negative option values (`--max-delay-s -2`) were parsed as unknown
/// flags. Every subcommand takes them as values: the command's own range
/// check answers.
#[test]
fn a_negative_value_is_a_value_and_meets_its_range() {
    let out = magcal(&["swing", "--input", "nowhere.csv", "--estimate-delay", "--max-delay-s", "-2"]);
    let err = stderr(&out);
    assert!(!out.status.success() && !err.contains("unexpected argument"), "{err}");
    assert!(err.contains("--max-delay-s") && err.contains("-2"), "{err}");
    let out = magcal(&["simulate", "swing", "--roll-amp-deg", "-5", "--out", "x.csv"]);
    let err = stderr(&out);
    assert!(out.status.code() == Some(1) && err.contains("--roll-amp-deg") && err.contains("0 … 90 degrees") && !err.contains("unexpected argument"), "{err}");
}

/// `report --field-nt 5` was accepted; every numeric option of report,
/// card, simulate and log now has a stated range in its parser: one line,
/// status 1, the range named, before any work.
#[test]
fn numeric_options_have_stated_ranges() {
    let dir = tempfile::tempdir().unwrap();
    let x = dir.path().join("x.csv");
    let cases: [(&[&str], &str); 7] = [
        (&["report", "--field-nt", "5", "--out", p(dir.path())], "5 nT is not a geomagnetic field intensity"),
        (&["report", "--field-nt", "nan", "--out", p(dir.path())], "--field-nt"),
        (&["simulate", "swing", "--rate-hz", "nan", "--out", p(&x)], "0.1 … 1000 Hz"),
        (&["simulate", "run", "--gps-delay-s", "-1", "--out", p(&x)], "0 … 60 s"),
        (&["log", "--port", "/nonexistent", "--out", p(&x), "--duration-s", "nan"], "0.1 … 2592000 s"),
        (&["log", "--port", "/nonexistent", "--out", p(&x), "--rate-hz", "0"], "--rate-hz"),
        (&["card", "--input", p(&x), "--cal", p(&x), "--step-deg", "inf"], "0.1 … 180 degrees"),
    ];
    for (args, says) in cases {
        let out = magcal(args);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
        assert!(err.contains(says) && err.trim_end().lines().count() == 1, "{args:?}: {err}");
        assert!(!x.exists());
    }
}

/// `session --nav-run out/run.csv --out out`: the session writes
/// `out/run.csv` at the end of the run it is reading. Every file the session
/// and its report write is checked against the navigation streams before
/// the port is touched.
#[test]
fn session_refuses_a_navigation_stream_among_its_files() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("session");
    std::fs::create_dir(&out).unwrap();
    let nav = "t,roll_deg,pitch_deg,ref_heading_deg,lat_deg,lon_deg\n0,0,0,10,36.9,50.6\n";
    let (swing_nav, run_nav) = (dir.path().join("swing_nav.csv"), out.join("run.csv"));
    std::fs::write(&swing_nav, nav).unwrap();
    std::fs::write(&run_nav, nav).unwrap();
    let o = magcal(&[
        "session", "--port", "/nonexistent", "--nav-swing", p(&swing_nav), "--nav-run", p(&run_nav), "--lat", "36.9", "--lon", "50.6", "--date", "2021-01-01", "--out", p(&out),
    ]);
    let err = stderr(&o);
    assert!(!o.status.success() && err.contains("run.csv is the input") && !err.contains("serial port"), "{err}");
    assert_eq!(std::fs::read_to_string(&run_nav).unwrap(), nav);
}
