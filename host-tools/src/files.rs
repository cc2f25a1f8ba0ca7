//! Output files that never lose data: the checks every command makes on
//! an output path before any work, and the one way every output is
//! written — a unique temporary file in the output's own folder, flushed
//! to disk and renamed over the target, so a reader sees the old file or
//! the new one, never half of one, and two writers never share a
//! temporary (the `tempfile` crate: unique names).
//!
//! * A replaced file keeps its mode, and its owner and group where the
//!   user may set them; a new file gets the default mode (0666 less the
//!   umask), not the temporary's private 0600.
//! * A read-only file (no write bit for anyone, e.g. 0444) is not replaced:
//!   [`OutputError::ReadOnly`]. A folder that cannot be written is refused
//!   by [`check_output`], before any work.
//! * Every live temporary is listed in one process-wide registry; after
//!   [`remove_temporaries_on_signals`], SIGINT, SIGTERM and SIGHUP remove
//!   them before the process exits (status 128 + the signal). A temporary
//!   is created, renamed and removed under the registry's lock, so a signal
//!   never sees half of one of these steps.
//! * Several outputs that belong together (a recording and its truth) are
//!   written by [`write_together`]: every target checked, every temporary
//!   written, and only then each renamed.

use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard};

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
    /// The output exists and is read-only (no write bit for anyone): it
    /// is kept, not silently replaced.
    #[error("{}: is read-only (mode {mode:04o}): it is not replaced (make it writable, e.g. chmod u+w, or write to another file)", path.display())]
    ReadOnly {
        /// The output path.
        path: PathBuf,
        /// Its permission bits.
        mode: u32,
    },
    /// Nothing can be created in the output's folder (its permissions, a
    /// read-only file system).
    #[error("{}: the folder {} cannot be written ({source})", path.display(), folder.display())]
    FolderNotWritable {
        /// The output path.
        path: PathBuf,
        /// Its folder.
        folder: PathBuf,
        /// What the OS said.
        #[source]
        source: std::io::Error,
    },
    /// The same output named twice in one [`write_together`].
    #[error("{}: named twice among the outputs", path.display())]
    Duplicate {
        /// The output path.
        path: PathBuf,
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

/// The permission bits of a file (0 where there are none to read).
fn mode_of(meta: &std::fs::Metadata) -> u32 {
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        meta.permissions().mode() & 0o7777
    }
    #[cfg(not(unix))]
    {
        if meta.permissions().readonly() {
            0o444
        } else {
            0o666
        }
    }
}

/// What an output path names on disk: refused when it is not a regular
/// file or is read-only; the file a write reaches (through a symbolic link,
/// the file it points at) and whether it exists.
fn resolve(out: &Path) -> Result<(PathBuf, Replaces), OutputError> {
    // `symlink_metadata` would judge the link itself; the target is what
    // a write reaches, so follow it.
    match std::fs::metadata(out) {
        Ok(meta) => {
            if let Some(what) = not_a_file(&meta) {
                return Err(OutputError::NotAFile { path: out.into(), what });
            }
            if meta.permissions().readonly() {
                return Err(OutputError::ReadOnly { path: out.into(), mode: mode_of(&meta) });
            }
            let target = out.canonicalize().map_err(|source| OutputError::Io { path: out.into(), source })?;
            Ok((target, Replaces::ExistingFile))
        }
        Err(_) => Ok((out.to_path_buf(), Replaces::Nothing)),
    }
}

/// Checks an output path before any work: a regular file or nothing (not
/// a directory, a device, a pipe), not read-only, in a folder that exists
/// and can be written (a temporary file is created there and removed: the
/// test that holds for permissions, read-only file systems and the
/// superuser alike), and none of `inputs` (compared on disk: a hard or
/// symbolic link to an input is the input). Says whether an existing file
/// would be replaced.
pub fn check_output(out: &Path, inputs: &[&Path]) -> Result<Replaces, OutputError> {
    if let Some(input) = inputs.iter().find(|i| same_file(out, i)) {
        return Err(OutputError::IsAnInput { out: out.into(), input: input.to_path_buf() });
    }
    let (target, replaces) = resolve(out)?;
    let folder = folder_of(&target);
    if !folder.is_dir() {
        return Err(OutputError::NoFolder { path: out.into(), folder: folder_of(out).into() });
    }
    let probe = Temporary::create(folder, ".tmp").map_err(|source| OutputError::FolderNotWritable { path: out.into(), folder: folder.into(), source })?;
    drop(probe);
    Ok(replaces)
}

/// The live temporaries of this process, removed on SIGINT, SIGTERM and
/// SIGHUP (see [`remove_temporaries_on_signals`]).
static LIVE: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// The registry, locked (a panic elsewhere does not stop the clean-up).
fn live() -> MutexGuard<'static, Vec<PathBuf>> {
    LIVE.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// Removes this process's temporaries when it receives SIGINT, SIGTERM or
/// SIGHUP, then exits with status 128 + the signal's number. The signals
/// are received on a thread of their own (`signal-hook`), where removing
/// files is safe; the registry stays locked until the exit, so no new
/// temporary is made and none is renamed meanwhile. A later handler for
/// one of these signals (`magcal log` ends its log cleanly on SIGINT and
/// SIGTERM) replaces this one for that signal. Call it once, at the start.
#[cfg(unix)]
pub fn remove_temporaries_on_signals() -> std::io::Result<()> {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    let mut signals = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP])?;
    std::thread::Builder::new().name("magcal-signals".into()).spawn(move || {
        if let Some(signal) = signals.forever().next() {
            let paths = live();
            for p in paths.iter() {
                let _ = std::fs::remove_file(p);
            }
            std::process::exit(128 + signal);
        }
    })?;
    Ok(())
}

/// A temporary file beside an output, listed in the process's registry of
/// temporaries: written through [`Temporary::file_mut`] (or whole at
/// [`Temporary::path`]), then [`Temporary::commit`]ted over its target, or
/// removed when dropped.
#[derive(Debug)]
pub struct Temporary {
    file: File,
    path: PathBuf,
    /// The output path as given (for errors).
    out: PathBuf,
    /// The file it replaces (through a symbolic link, the link's target).
    target: PathBuf,
    committed: bool,
}

impl Temporary {
    /// A new unique temporary `.magcal-XXXXXX<suffix>` in `folder`, with the
    /// default mode (0666 less the umask), listed in the registry.
    fn create(folder: &Path, suffix: &str) -> std::io::Result<Self> {
        let mut live = live();
        let mut b = tempfile::Builder::new();
        b.prefix(".magcal-").suffix(suffix);
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            // Through open(2): the umask applies, as to any new file.
            b.permissions(std::fs::Permissions::from_mode(0o666));
        }
        // The OS's error alone: tempfile adds the temporary's name, and the
        // output's is the one to say.
        let bare = |e: std::io::Error| match e.to_string().split_once(" at path ") {
            Some((os, _)) => std::io::Error::new(e.kind(), os.to_string()),
            None => e,
        };
        let (file, path) = b.tempfile_in(folder).map_err(bare)?.keep().map_err(|e| e.error)?;
        live.push(path.clone());
        Ok(Self { file, out: PathBuf::new(), target: PathBuf::new(), path, committed: false })
    }

    /// A named temporary `name` in `folder` (none there yet), listed.
    fn create_named(folder: &Path, name: &str) -> std::io::Result<Self> {
        let mut live = live();
        // Absolute, as `tempfile` makes its own: the batch's paths compare.
        let path = std::path::absolute(folder)?.join(name);
        let file = std::fs::OpenOptions::new().write(true).create_new(true).open(&path)?;
        live.push(path.clone());
        Ok(Self { file, out: PathBuf::new(), target: PathBuf::new(), path, committed: false })
    }

    /// A temporary for `out` in the folder of the file it will replace
    /// (refused when `out` is not a regular file or is read-only).
    pub fn beside(out: &Path) -> Result<Self, OutputError> {
        let (target, _) = resolve(out)?;
        let mut t = Self::create(folder_of(&target), ".tmp").map_err(|source| OutputError::Io { path: out.into(), source })?;
        (t.out, t.target) = (out.into(), target);
        Ok(t)
    }

    /// The temporary's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The temporary, open for writing.
    pub fn file_mut(&mut self) -> &mut File {
        &mut self.file
    }

    /// Renames the temporary over its target, synced to disk first. A file
    /// it replaces keeps its mode, and its owner and group where this user
    /// may set them; a target made read-only meanwhile is kept.
    pub fn commit(mut self) -> Result<(), OutputError> {
        let io = |source| OutputError::Io { path: self.out.clone(), source };
        self.file.flush().map_err(io)?;
        // The file at the path (a writer may have replaced it whole).
        File::open(&self.path).and_then(|f| f.sync_all()).map_err(io)?;
        if let Ok(meta) = std::fs::metadata(&self.target) {
            if meta.permissions().readonly() {
                return Err(OutputError::ReadOnly { path: self.out.clone(), mode: mode_of(&meta) });
            }
            #[cfg(unix)]
            {
                use std::os::unix::fs::MetadataExt;
                // Not permitted (another user's file): it becomes ours.
                let _ = std::os::unix::fs::chown(&self.path, Some(meta.uid()), Some(meta.gid()));
            }
            std::fs::set_permissions(&self.path, meta.permissions()).map_err(io)?;
        }
        let mut live = live();
        std::fs::rename(&self.path, &self.target).map_err(io)?;
        live.retain(|p| p != &self.path);
        self.committed = true;
        Ok(())
    }
}

impl Drop for Temporary {
    fn drop(&mut self) {
        if !self.committed {
            let mut live = live();
            let _ = std::fs::remove_file(&self.path);
            live.retain(|p| p != &self.path);
        }
    }
}

/// Writes `path` whole through `write`: into a unique temporary file in the
/// same folder, flushed and synced, then renamed over `path` (atomic on
/// one file system). On any error the temporary is removed and `path` is
/// as it was. Refuses a `path` that exists and is not a regular file (a
/// rename would replace a device node with a file) or is read-only. A
/// symbolic link is written through: its target is replaced. The file
/// keeps the mode (and owner) of the one it replaces.
pub fn write_atomic(path: &Path, write: impl FnOnce(&mut File) -> std::io::Result<()>) -> Result<(), OutputError> {
    let mut tmp = Temporary::beside(path)?;
    write(tmp.file_mut()).map_err(|source| OutputError::Io { path: path.into(), source })?;
    tmp.commit()
}

/// [`write_atomic`] of a text.
pub fn write_text_atomic(path: &Path, text: &str) -> Result<(), OutputError> {
    write_atomic(path, |f| f.write_all(text.as_bytes()))
}

/// Writes outputs that belong together (a recording and its truth): every
/// target checked as [`write_atomic`] checks one, a temporary made for each
/// in its target's folder, `write` given the temporaries' paths (in the
/// order of `targets`) to write each whole, and only when it succeeded is
/// each renamed over its target, in turn.
///
/// Not atomic as a whole: a crash between two renames leaves the first
/// target new and the second old. But no target is touched until every
/// temporary is written, so a refused or failed output (a directory, a
/// pipe, a full disk) leaves every target as it was.
///
/// Temporaries sharing a folder share a unique stem and keep their
/// targets' names: `x.csv` and `x.truth.json` are written as
/// `.magcal-R-x.csv` and `.magcal-R-x.truth.json`, so a writer that names
/// the second file after the first finds the right temporary.
pub fn write_together<E: From<OutputError>>(targets: &[&Path], write: impl FnOnce(&[PathBuf]) -> Result<(), E>) -> Result<(), E> {
    let mut resolved = Vec::with_capacity(targets.len());
    for out in targets {
        let (target, _) = resolve(out)?;
        if resolved.iter().any(|(_, t)| t == &target) {
            return Err(OutputError::Duplicate { path: out.to_path_buf() }.into());
        }
        resolved.push((out.to_path_buf(), target));
    }
    let mut temps: Vec<Temporary> = Vec::with_capacity(targets.len());
    let mut stem: Option<String> = None;
    for (out, target) in resolved {
        let io = |source| OutputError::Io { path: out.clone(), source };
        let folder = folder_of(&target);
        let name = target.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        let mut t = match &stem {
            Some(r) => Temporary::create_named(folder, &format!(".magcal-{r}-{name}")).map_err(io)?,
            None => {
                let t = Temporary::create(folder, &format!("-{name}")).map_err(io)?;
                let file = t.path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
                stem = file.strip_prefix(".magcal-").and_then(|f| f.strip_suffix(&format!("-{name}"))).map(str::to_string);
                t
            }
        };
        (t.out, t.target) = (out, target);
        temps.push(t);
    }
    let paths: Vec<PathBuf> = temps.iter().map(|t| t.path.clone()).collect();
    write(&paths)?;
    for t in temps {
        t.commit()?;
    }
    Ok(())
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
        // the three texts), none fails (a shared `.tmp` name once made
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

    /// The umask of this process, read without changing it (Linux's
    /// /proc/self/status; 0o022 where it is not shown).
    #[cfg(unix)]
    fn umask() -> u32 {
        std::fs::read_to_string("/proc/self/status")
            .ok()
            .and_then(|s| s.lines().find_map(|l| l.strip_prefix("Umask:").and_then(|v| u32::from_str_radix(v.trim(), 8).ok())))
            .unwrap_or(0o022)
    }

    #[cfg(unix)]
    #[test]
    fn a_replaced_file_keeps_its_mode_and_a_new_one_gets_the_default() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o7777;
        // Shared with a team: 0644 stays 0644 (it once became 0600).
        let shared = dir.path().join("shared.csv");
        std::fs::write(&shared, "old").unwrap();
        std::fs::set_permissions(&shared, std::fs::Permissions::from_mode(0o644)).unwrap();
        write_text_atomic(&shared, "new").unwrap();
        assert_eq!((mode(&shared), std::fs::read_to_string(&shared).unwrap().as_str()), (0o644, "new"));
        // 0640 too (not simply the default).
        std::fs::set_permissions(&shared, std::fs::Permissions::from_mode(0o640)).unwrap();
        write_text_atomic(&shared, "newer").unwrap();
        assert_eq!(mode(&shared), 0o640);
        // A new file: 0666 less the umask, as `touch` would make it.
        let fresh = dir.path().join("fresh.csv");
        write_text_atomic(&fresh, "x").unwrap();
        assert_eq!(mode(&fresh), 0o666 & !umask());
        // Read-only: refused by the check and by the writer, kept as it is.
        let kept = dir.path().join("kept.csv");
        std::fs::write(&kept, "precious").unwrap();
        std::fs::set_permissions(&kept, std::fs::Permissions::from_mode(0o444)).unwrap();
        let e = check_output(&kept, &[]).unwrap_err();
        assert!(matches!(e, OutputError::ReadOnly { mode: 0o444, .. }) && e.to_string().contains("kept.csv: is read-only (mode 0444)"), "{e}");
        assert!(matches!(write_text_atomic(&kept, "lost"), Err(OutputError::ReadOnly { .. })));
        assert_eq!(std::fs::read_to_string(&kept).unwrap(), "precious");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 3, "no temporary left");
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn a_folder_that_cannot_be_written_is_refused_by_the_check() {
        // sysfs refuses new files even to the superuser (tests run as
        // root, for whom a 0555 folder is writable).
        let out = Path::new("/sys/out.csv");
        let e = check_output(out, &[]).unwrap_err();
        let text = e.to_string();
        assert!(matches!(e, OutputError::FolderNotWritable { .. }), "{text}");
        assert!(text.starts_with("/sys/out.csv: the folder /sys cannot be written") && !text.contains(".magcal-"), "{text}");
    }

    #[test]
    fn outputs_written_together_are_all_kept_when_one_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let csv = dir.path().join("x.csv");
        let truth = dir.path().join("x.truth.json");
        std::fs::write(&csv, "old csv").unwrap();
        std::fs::create_dir(&truth).unwrap();
        let mut called = false;
        let e = write_together::<OutputError>(&[&csv, &truth], |_| {
            called = true;
            Ok(())
        })
        .unwrap_err();
        assert!(matches!(e, OutputError::NotAFile { what: "a directory", .. }), "{e}");
        assert!(!called, "refused before any work");
        assert_eq!(std::fs::read_to_string(&csv).unwrap(), "old csv");
        // A writer that fails: nothing replaced, no temporary left.
        std::fs::remove_dir(&truth).unwrap();
        let e = write_together(&[&csv, &truth], |temps| {
            std::fs::write(&temps[0], "new csv").unwrap();
            Err(OutputError::Io { path: truth.clone(), source: std::io::Error::other("disk full") })
        });
        assert!(e.is_err());
        assert_eq!(std::fs::read_to_string(&csv).unwrap(), "old csv");
        assert!(!truth.exists());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
        // Both written: the temporaries share a stem and keep the names.
        write_together::<OutputError>(&[&csv, &truth], |temps| {
            let name = |i: usize| temps[i].file_name().unwrap().to_string_lossy().into_owned();
            assert!(name(0).starts_with(".magcal-") && name(0).ends_with("-x.csv"), "{}", name(0));
            assert_eq!(temps[0].with_extension("truth.json"), temps[1]);
            std::fs::write(&temps[0], "new csv").unwrap();
            std::fs::write(&temps[1], "{}").unwrap();
            Ok(())
        })
        .unwrap();
        assert_eq!(std::fs::read_to_string(&csv).unwrap(), "new csv");
        assert_eq!(std::fs::read_to_string(&truth).unwrap(), "{}");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
        // None of this test's temporaries is still listed (other tests'
        // may be, at once).
        assert!(live().iter().all(|p| !p.starts_with(dir.path())));
    }

    #[cfg(unix)]
    #[test]
    fn a_replaced_file_keeps_its_owner_where_this_user_may_set_it() {
        use std::os::unix::fs::MetadataExt;
        let dir = tempfile::tempdir().unwrap();
        let team = dir.path().join("team.csv");
        std::fs::write(&team, "old").unwrap();
        if std::fs::metadata(&team).unwrap().uid() != 0 {
            // Only the superuser may give a file to another user (the
            // tests and CI run as root, where this checks the owner kept).
            return;
        }
        std::os::unix::fs::chown(&team, Some(4321), Some(4322)).unwrap();
        write_text_atomic(&team, "new").unwrap();
        let meta = std::fs::metadata(&team).unwrap();
        assert_eq!((meta.uid(), meta.gid()), (4321, 4322));
        assert_eq!(std::fs::read_to_string(&team).unwrap(), "new");
    }
}
