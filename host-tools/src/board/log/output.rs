//! The board log's file: checked when made, created at the first write,
//! and replacing an old log only once it holds samples.

use std::io::{self, Write};
use std::path::PathBuf;

use super::LogError;

/// The board log's file, made by [`create_log_file`]: checked when made,
/// created only when its first bytes come (the port open and a board
/// answering), written and flushed as the rows arrive.
///
/// A new log is written at its path directly (a killed process loses
/// nothing it had written). One that replaces an existing log (`force`)
/// is written to a temporary beside it ([`crate::files::Temporary`]) and
/// renamed over the old log by [`LogOutput::finish`] only when it holds
/// samples: a port that does not open, a board that does not answer or a
/// log ended before its first sample leave the old log as it was.
#[derive(Debug)]
pub struct LogOutput {
    path: PathBuf,
    /// An existing log is to be replaced.
    replaces: bool,
    file: LogFile,
    /// Line ends written (the header's and one per row).
    lines: u64,
}

#[derive(Debug)]
enum LogFile {
    /// Nothing written yet: nothing made.
    NotYet,
    /// A new file at the path.
    Live(std::fs::File),
    /// A temporary that replaces the old log when it holds samples.
    Replacing(crate::files::Temporary),
}

/// Checks the output for a new log (before the port is touched): refused
/// when it exists unless `force`, and as [`crate::files::check_output`]
/// refuses it (a directory, a device, a pipe, a read-only file, a folder
/// that cannot be written). Nothing is created until the first write.
pub fn create_log_file(path: &std::path::Path, force: bool) -> Result<LogOutput, LogError> {
    if !force && std::fs::symlink_metadata(path).is_ok() {
        return Err(LogError::Exists(path.to_path_buf()));
    }
    // Never a directory, a device or a pipe, even with --force.
    let replaces = crate::files::check_output(path, &[])? == crate::files::Replaces::ExistingFile;
    Ok(LogOutput { path: path.to_path_buf(), replaces, file: LogFile::NotYet, lines: 0 })
}

impl LogOutput {
    /// Whether rows were written beyond the header.
    pub fn holds_samples(&self) -> bool {
        self.lines > 1
    }

    /// Whether an existing log is to be replaced (`force` on a log there).
    pub fn replaces(&self) -> bool {
        self.replaces
    }

    /// Ends the file. With samples: a new log stays, a replacing one is
    /// renamed over the old log (keeping its mode). Without: the
    /// replacing temporary is removed (the old log kept as it was); a new
    /// log holding its header alone is removed when `logged` is false
    /// (logging failed), kept otherwise (a log that ran and saw nothing).
    pub fn finish(self, logged: bool) -> Result<(), LogError> {
        let samples = self.holds_samples();
        match self.file {
            LogFile::NotYet => Ok(()),
            LogFile::Live(file) => {
                drop(file);
                if !samples && !logged {
                    std::fs::remove_file(&self.path).map_err(|source| LogError::Io { path: self.path.clone(), source })?;
                }
                Ok(())
            }
            LogFile::Replacing(tmp) if samples => Ok(tmp.commit()?),
            LogFile::Replacing(tmp) => {
                drop(tmp);
                Ok(())
            }
        }
    }

    /// The file, made at the first write.
    fn file(&mut self) -> io::Result<&mut dyn Write> {
        if let LogFile::NotYet = self.file {
            self.file = if self.replaces {
                LogFile::Replacing(crate::files::Temporary::beside(&self.path).map_err(io::Error::other)?)
            } else {
                // Not there when checked: still not there, or it is not ours.
                LogFile::Live(std::fs::OpenOptions::new().write(true).create_new(true).open(&self.path)?)
            };
        }
        Ok(match &mut self.file {
            LogFile::Live(f) => f,
            LogFile::Replacing(t) => t.file_mut(),
            LogFile::NotYet => unreachable!("made above"),
        })
    }
}

impl Write for LogOutput {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let n = self.file()?.write(buf)?;
        self.lines += buf[..n].iter().filter(|&&b| b == b'\n').count() as u64;
        Ok(n)
    }

    fn flush(&mut self) -> io::Result<()> {
        match &mut self.file {
            LogFile::NotYet => Ok(()),
            LogFile::Live(f) => f.flush(),
            LogFile::Replacing(t) => t.file_mut().flush(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::LOG_HEADER;
    use super::*;

    #[test]
    fn an_existing_output_is_refused_unless_forced() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("board.csv");
        std::fs::write(&p, "keep me").unwrap();
        let e = create_log_file(&p, false).unwrap_err();
        assert!(matches!(&e, LogError::Exists(p) if p == &dir.path().join("board.csv")) && e.to_string().contains("exists"), "{e}");
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "keep me");
        // Forced, nothing written (the port did not open): the old log kept
        // (it was once truncated to nothing).
        create_log_file(&p, true).unwrap().finish(false).unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "keep me");
    }

    #[test]
    fn a_forced_log_replaces_the_old_one_only_when_it_holds_samples() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("board.csv");
        let old = "t,mx\n1,2\n";
        std::fs::write(&p, old).unwrap();
        #[cfg(unix)]
        std::fs::set_permissions(&p, std::os::unix::fs::PermissionsExt::from_mode(0o644)).unwrap();
        let listing = || {
            let mut v: Vec<String> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
            v.sort();
            v
        };
        // The header alone (the board stopped before its first sample).
        let mut out = create_log_file(&p, true).unwrap();
        out.write_all(format!("{LOG_HEADER}\n").as_bytes()).unwrap();
        out.flush().unwrap();
        assert!(!out.holds_samples() && out.replaces());
        assert_eq!(std::fs::read_to_string(&p).unwrap(), old, "the old log untouched while logging");
        out.finish(true).unwrap();
        assert_eq!((std::fs::read_to_string(&p).unwrap().as_str(), listing()), (old, vec!["board.csv".to_string()]));
        // With rows: replaced, keeping the old file's mode.
        let mut out = create_log_file(&p, true).unwrap();
        let new = format!("{LOG_HEADER}\n0.010,1,2,3,,0,,ok\n");
        out.write_all(new.as_bytes()).unwrap();
        assert!(out.holds_samples());
        out.finish(true).unwrap();
        assert_eq!((std::fs::read_to_string(&p).unwrap(), listing()), (new, vec!["board.csv".to_string()]));
        #[cfg(unix)]
        assert_eq!(std::os::unix::fs::PermissionsExt::mode(&std::fs::metadata(&p).unwrap().permissions()) & 0o777, 0o644);
        // A new log that failed before its first row leaves nothing; one
        // that ran and saw nothing keeps its header.
        let q = dir.path().join("new.csv");
        let mut out = create_log_file(&q, false).unwrap();
        out.write_all(b"t,mx\n").unwrap();
        out.finish(false).unwrap();
        assert!(!q.exists());
        let mut out = create_log_file(&q, false).unwrap();
        out.write_all(b"t,mx\n").unwrap();
        out.finish(true).unwrap();
        assert_eq!(std::fs::read_to_string(&q).unwrap(), "t,mx\n");
    }
}
