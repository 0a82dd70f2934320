//! Files beneath a served folder, opened without following symbolic links.
//!
//! A [`Root`] holds its folder open. A file under it is opened one path
//! component at a time relative to the component before (`openat` with
//! `O_NOFOLLOW`), so that neither a symbolic link in the request's path nor
//! one put in place of a file after the server started leads out of the
//! folder; the opened handle must be a regular file. On systems without
//! `openat` the same rule is checked by path, which a concurrent swap can
//! race.

use std::fs::{File, Metadata};
use std::io;
use std::path::{Path, PathBuf};
use std::time::{SystemTime, UNIX_EPOCH};

/// A served folder.
pub struct Root {
    path: PathBuf,
    #[cfg(unix)]
    dir: std::os::fd::OwnedFd,
}

/// A file opened for a response, with what identifies its version.
pub struct Opened {
    pub file: File,
    pub len: u64,
    /// Whole seconds: HTTP dates have no finer resolution.
    pub modified: SystemTime,
    /// A strong validator: changes when the file is replaced or written.
    pub etag: String,
}

impl Root {
    /// Opens the folder `path` (following a link the caller named itself).
    pub fn open(path: &Path) -> io::Result<Root> {
        #[cfg(unix)]
        {
            use rustix::fs::{CWD, Mode, OFlags, openat};
            let flags = OFlags::RDONLY | OFlags::DIRECTORY | OFlags::CLOEXEC;
            let dir = openat(CWD, path, flags, Mode::empty())?;
            Ok(Root {
                path: path.to_path_buf(),
                dir,
            })
        }
        #[cfg(not(unix))]
        {
            if !std::fs::metadata(path)?.is_dir() {
                return Err(io::Error::other("not a folder"));
            }
            Ok(Root {
                path: path.to_path_buf(),
            })
        }
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The regular file at `relative` (components separated by `/`), with
    /// no symbolic link on the way and no `.`, `..` or empty component.
    pub fn open_file(&self, relative: &str) -> io::Result<Opened> {
        let parts: Vec<&str> = relative.split('/').collect();
        if parts
            .iter()
            .any(|p| p.is_empty() || *p == "." || *p == "..")
        {
            return Err(io::Error::new(
                io::ErrorKind::NotFound,
                "not a plain relative path",
            ));
        }
        let file = self.open_beneath(&parts)?;
        let meta = file.metadata()?;
        if !meta.is_file() {
            return Err(io::Error::new(
                io::ErrorKind::NotFound,
                "not a regular file",
            ));
        }
        Ok(Opened::new(file, &meta))
    }

    #[cfg(unix)]
    fn open_beneath(&self, parts: &[&str]) -> io::Result<File> {
        use rustix::fs::{Mode, OFlags, openat};
        use std::os::fd::AsFd;
        let mut dir = None;
        for (i, part) in parts.iter().enumerate() {
            let at = dir
                .as_ref()
                .map_or(self.dir.as_fd(), |d: &std::os::fd::OwnedFd| d.as_fd());
            let base = OFlags::RDONLY | OFlags::NOFOLLOW | OFlags::CLOEXEC | OFlags::NOCTTY;
            if i + 1 < parts.len() {
                dir = Some(openat(at, *part, base | OFlags::DIRECTORY, Mode::empty())?);
            } else {
                // Non-blocking, so that a FIFO put here does not hold the
                // thread until a writer comes; it is refused as not a
                // regular file, and reads of a regular file ignore the flag.
                let fd = openat(at, *part, base | OFlags::NONBLOCK, Mode::empty())?;
                return Ok(File::from(fd));
            }
        }
        Err(io::ErrorKind::NotFound.into())
    }

    #[cfg(not(unix))]
    fn open_beneath(&self, parts: &[&str]) -> io::Result<File> {
        let mut path = self.path.clone();
        for part in parts {
            path.push(part);
            if std::fs::symlink_metadata(&path)?.file_type().is_symlink() {
                return Err(io::Error::new(io::ErrorKind::NotFound, "a symbolic link"));
            }
        }
        File::open(path)
    }
}

impl Opened {
    fn new(file: File, meta: &Metadata) -> Opened {
        let since_epoch = meta
            .modified()
            .ok()
            .and_then(|t| t.duration_since(UNIX_EPOCH).ok())
            .unwrap_or_default();
        #[cfg(unix)]
        let inode = std::os::unix::fs::MetadataExt::ino(meta);
        #[cfg(not(unix))]
        let inode = 0u64;
        Opened {
            file,
            len: meta.len(),
            modified: UNIX_EPOCH + std::time::Duration::from_secs(since_epoch.as_secs()),
            etag: format!(
                "\"{inode:x}-{:x}-{:x}.{:x}\"",
                meta.len(),
                since_epoch.as_secs(),
                since_epoch.subsec_nanos()
            ),
        }
    }
}

/// The `Content-Type` of a file, by its extension.
pub fn content_type(name: &str) -> &'static str {
    let extension = name.rsplit_once('.').map_or("", |(_, e)| e);
    match extension.to_ascii_lowercase().as_str() {
        "html" | "htm" => "text/html; charset=utf-8",
        "js" | "mjs" => "text/javascript; charset=utf-8",
        "css" => "text/css; charset=utf-8",
        "json" => "application/json",
        "wasm" => "application/wasm",
        "png" => "image/png",
        "jpg" | "jpeg" => "image/jpeg",
        "svg" => "image/svg+xml",
        "ico" => "image/x-icon",
        "txt" => "text/plain; charset=utf-8",
        "glb" => "model/gltf-binary",
        "gltf" => "model/gltf+json",
        // .qm, .bin and anything else.
        _ => "application/octet-stream",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn files_open_beneath_the_root_only() {
        let dir = tempfile::tempdir().unwrap();
        let outside = tempfile::tempdir().unwrap();
        std::fs::write(outside.path().join("secret"), b"secret").unwrap();
        let root_path = dir.path().join("root");
        std::fs::create_dir_all(root_path.join("sub")).unwrap();
        std::fs::write(root_path.join("sub/a.txt"), b"inside").unwrap();
        let root = Root::open(&root_path).unwrap();
        let opened = root.open_file("sub/a.txt").unwrap();
        assert_eq!(opened.len, 6);
        assert!(opened.etag.starts_with('"') && opened.etag.ends_with('"'));
        for bad in [
            "",
            "sub",
            "sub/",
            "/sub/a.txt",
            "sub//a.txt",
            "../root/sub/a.txt",
            "sub/./a.txt",
            "missing",
        ] {
            assert!(root.open_file(bad).is_err(), "{bad:?}");
        }
        #[cfg(unix)]
        {
            use std::os::unix::fs::symlink;
            symlink(outside.path().join("secret"), root_path.join("link")).unwrap();
            symlink(outside.path(), root_path.join("dirlink")).unwrap();
            symlink("sub/a.txt", root_path.join("inner")).unwrap();
            for bad in ["link", "dirlink/secret", "inner"] {
                assert!(root.open_file(bad).is_err(), "{bad:?}");
            }
        }
        #[cfg(target_os = "linux")]
        {
            // A FIFO is refused at once, not waited on.
            let fifo = root_path.join("fifo");
            use rustix::fs::{CWD, FileType, Mode, mknodat};
            mknodat(CWD, &fifo, FileType::Fifo, Mode::RUSR | Mode::WUSR, 0).unwrap();
            assert!(root.open_file("fifo").is_err());
        }
    }

    #[test]
    fn types_by_extension() {
        assert_eq!(content_type("a.WASM"), "application/wasm");
        assert_eq!(content_type("x.mjs"), "text/javascript; charset=utf-8");
        assert_eq!(content_type("s.glb"), "model/gltf-binary");
        assert_eq!(content_type("s.gltf"), "model/gltf+json");
        assert_eq!(content_type("spot.qm"), "application/octet-stream");
        assert_eq!(content_type("noext"), "application/octet-stream");
    }
}
