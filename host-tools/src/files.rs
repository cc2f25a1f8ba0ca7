//! Output files that never lose data: the checks every command makes on
//! an output path before any work, and the one way every output is
//! written — a unique temporary file in the output's own folder, flushed
//! to disk and renamed over the target, so a reader sees the old file or
//! the new one, never half of one, and two writers never share a
//! temporary (the `tempfile` crate: unique names, removed on any error).

use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Why an output path is refused or could not be written.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// The output path names something that is not a regular file.
    #[error("{}: is {what}, not a file: give a file's path", path.display())]
    NotAFile {
        /// The output path.
        path: PathBuf,
        /// What it is ("a directory", "a device", …).
        what: &'static str,
    },
    /// The output's folder does not exist.
    #[error("{}: the folder {} does not exist", path.display(), folder.display())]
    NoFolder {
        /// The output path.
        path: PathBuf,
        /// Its folder.
        folder: PathBuf,
    },
    /// The output is one of the inputs (the same path, a hard link or a
    /// symbolic link to it): writing would destroy it.
    #[error("{} is the input {} (the same file on disk): it would be overwritten (write to another file)", out.display(), input.display())]
    IsAnInput {
        /// The output path.
        out: PathBuf,
        /// The input it is.
        input: PathBuf,
    },
    /// The file could not be written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What the OS said.
        #[source]
        source: std::io::Error,
    },
}

/// What a path on disk is, when it is not a regular file.
fn not_a_file(meta: &std::fs::Metadata) -> Option<&'static str> {
    let t = meta.file_type();
    if t.is_file() {
        return None;
    }
    if t.is_dir() {
        return Some("a directory");
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_block_device() || t.is_char_device() {
            return Some("a device");
        }
        if t.is_fifo() {
            return Some("a named pipe");
        }
        if t.is_socket() {
            return Some("a socket");
        }
    }
    Some("not a regular file")
}

/// Whether two paths name the same file on disk (through hard or symbolic
/// links: the same device and inode on Unix, the same canonical path
/// elsewhere); `false` when either does not exist.
pub fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        match (std::fs::metadata(a), std::fs::metadata(b)) {
            (Ok(x), Ok(y)) => x.dev() == y.dev() && x.ino() == y.ino(),
            _ => false,
        }
    }
    #[cfg(not(unix))]
    {
        matches!((a.canonicalize(), b.canonicalize()), (Ok(x), Ok(y)) if x == y)
    }
}

/// The folder an output path is written in (`.` for a bare file name).
fn folder_of(path: &Path) -> &Path {
    path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."))
}

/// Whether an output about to be written replaces an existing file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Replaces {
    /// Nothing there yet.
    Nothing,
    /// A regular file is there and will be replaced whole.
    ExistingFile,
}

/// Checks an output path before any work: a regular file or nothing (not
/// a directory, a device, a pipe), in a folder that exists, and none of
/// `inputs` (compared on disk: a hard or symbolic link to an input is the
/// input). Says whether an existing file would be replaced.
pub fn check_output(out: &Path, inputs: &[&Path]) -> Result<Replaces, OutputError> {
    // `symlink_metadata` would judge the link itself; the target is what
    // a write reaches, so follow it.
    let replaces = match std::fs::metadata(out) {
        Ok(meta) => {
            if let Some(what) = not_a_file(&meta) {
                return Err(OutputError::NotAFile { path: out.into(), what });
            }
            Replaces::ExistingFile
        }
        Err(_) => Replaces::Nothing,
    };
    let folder = folder_of(out);
    if !folder.is_dir() {
        return Err(OutputError::NoFolder { path: out.into(), folder: folder.into() });
    }
    if let Some(input) = inputs.iter().find(|i| same_file(out, i)) {
        return Err(OutputError::IsAnInput { out: out.into(), input: input.to_path_buf() });
    }
    Ok(replaces)
}

/// Writes `path` whole through `write`: into a unique temporary file in the
/// same folder, flushed and synced, then renamed over `path` (atomic on
/// one file system). On any error the temporary is removed and `path` is
/// as it was. Refuses a `path` that exists and is not a regular file (a
/// rename would replace a device node with a file). A symbolic link is
/// written through: its target is replaced.
pub fn write_atomic(path: &Path, write: impl FnOnce(&mut File) -> std::io::Result<()>) -> Result<(), OutputError> {
    let io = |source| OutputError::Io { path: path.into(), source };
    let target = match std::fs::metadata(path) {
        Ok(meta) => {
            if let Some(what) = not_a_file(&meta) {
                return Err(OutputError::NotAFile { path: path.into(), what });
            }
            // Through a symbolic link, the file it points at.
            path.canonicalize().map_err(io)?
        }
        Err(_) => path.to_path_buf(),
    };
    let mut tmp = tempfile::Builder::new().prefix(".magcal-").suffix(".tmp").tempfile_in(folder_of(&target)).map_err(io)?;
    write(tmp.as_file_mut()).map_err(io)?;
    tmp.as_file_mut().flush().map_err(io)?;
    tmp.as_file().sync_all().map_err(io)?;
    tmp.persist(&target).map_err(|e| io(e.error))?;
    Ok(())
}

/// [`write_atomic`] of a text.
pub fn write_text_atomic(path: &Path, text: &str) -> Result<(), OutputError> {
    write_atomic(path, |f| f.write_all(text.as_bytes()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_input_is_refused_through_a_hard_or_symbolic_link() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("run.csv");
        std::fs::write(&input, "t,mx\n1,2\n").unwrap();
        let hard = dir.path().join("hard.csv");
        std::fs::hard_link(&input, &hard).unwrap();
        for out in [input.clone(), hard.clone(), dir.path().join(".").join("run.csv")] {
            assert!(matches!(check_output(&out, &[&input]), Err(OutputError::IsAnInput { .. })), "{}", out.display());
        }
        #[cfg(unix)]
        {
            let soft = dir.path().join("soft.csv");
            std::os::unix::fs::symlink(&input, &soft).unwrap();
            assert!(matches!(check_output(&soft, &[&input]), Err(OutputError::IsAnInput { .. })));
        }
        // Another file: fine, and says it replaces one.
        let other = dir.path().join("other.csv");
        assert_eq!(check_output(&other, &[&input]).unwrap(), Replaces::Nothing);
        std::fs::write(&other, "x").unwrap();
        assert_eq!(check_output(&other, &[&input]).unwrap(), Replaces::ExistingFile);
        // The input untouched.
        assert_eq!(std::fs::read_to_string(&input).unwrap(), "t,mx\n1,2\n");
    }

    #[test]
    fn a_directory_a_device_or_a_missing_folder_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let e = check_output(dir.path(), &[]).unwrap_err();
        assert!(matches!(e, OutputError::NotAFile { what: "a directory", .. }), "{e}");
        #[cfg(unix)]
        {
            let e = check_output(Path::new("/dev/null"), &[]).unwrap_err();
            assert!(e.to_string().contains("a device"), "{e}");
            // And the writer never turns the node into a file.
            assert!(matches!(write_text_atomic(Path::new("/dev/null"), "x"), Err(OutputError::NotAFile { .. })));
        }
        let e = check_output(&dir.path().join("nowhere/out.csv"), &[]).unwrap_err();
        assert!(matches!(e, OutputError::NoFolder { .. }), "{e}");
    }

    #[test]
    fn a_failed_write_leaves_the_old_file_and_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out.csv");
        std::fs::write(&out, "old\n").unwrap();
        let r = write_atomic(&out, |f| {
            f.write_all(b"half")?;
            Err(std::io::Error::other("killed"))
        });
        assert!(r.is_err());
        assert_eq!(std::fs::read_to_string(&out).unwrap(), "old\n");
        let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(left.len(), 1, "{left:?}");
        write_text_atomic(&out, "new\n").unwrap();
        assert_eq!(std::fs::read_to_string(&out).unwrap(), "new\n");
    }

    #[test]
    fn writers_to_the_same_output_never_share_a_temporary() {
        // Three writers at once, many times: each write lands whole (one of
        // the three texts), none fails (issue 30: a shared `.tmp` name made
        // one in fifteen fail).
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("doc.json");
        for round in 0..20 {
            let texts: Vec<String> = (0..3).map(|k| format!("{{\"writer\": {k}, \"round\": {round}, \"pad\": \"{}\"}}\n", "x".repeat(20_000))).collect();
            std::thread::scope(|s| {
                for t in &texts {
                    let out = &out;
                    s.spawn(move || write_text_atomic(out, t).unwrap());
                }
            });
            let got = std::fs::read_to_string(&out).unwrap();
            assert!(texts.contains(&got), "round {round}: a mixed file");
        }
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[cfg(unix)]
    #[test]
    fn a_symbolic_link_is_written_through() {
        let dir = tempfile::tempdir().unwrap();
        let real = dir.path().join("real.csv");
        std::fs::write(&real, "old").unwrap();
        let link = dir.path().join("link.csv");
        std::os::unix::fs::symlink(&real, &link).unwrap();
        write_text_atomic(&link, "new").unwrap();
        assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
        assert_eq!(std::fs::read_to_string(&real).unwrap(), "new");
    }
}
