//! MAVLink FTP on a PC: a directory served as the vehicle's file system ([`DirFs`]), and the
//! client's operations on a [`Remote`], blocking.
//!
//! ```no_run
//! use std::time::Duration;
//! use ferrolink_io::mavlink::services::{self, Remote};
//! use ferrolink_io::mavlink::Connection;
//!
//! let mut link = Connection::open("udpin://0.0.0.0:14550", services::TABLE)?;
//! let vehicle = services::wait_for_vehicle(&mut link, Duration::from_secs(5))?
//!     .expect("no vehicle");
//! let mut remote = Remote::new(&mut link, vehicle);
//! for entry in remote.ftp_list("/")? {
//!     println!("{entry:?}");
//! }
//! let bytes = remote.ftp_get("/logs/flight.bin", |done, size| eprintln!("{done}/{size}"))?;
//! # Ok::<(), std::io::Error>(())
//! ```

use std::collections::HashMap;
use std::fs::{self, File, OpenOptions};
use std::io::{self, Read, Seek, SeekFrom, Write};
use std::path::{Component, Path, PathBuf};

use ferrolink_runtime::mavlink::service::ftp::{self, entries, Entry, EntryKind, FileSystem, Nak};

use super::services::Remote;
use super::wait::{block_on, Blocking, Wait};

/// A directory served as the file system: every path is taken below it, and nothing outside
/// it is read or written (`..`, and links that lead out, are refused).
#[derive(Debug)]
pub struct DirFs {
    root: PathBuf,
    open: HashMap<u8, (File, bool)>,
}

impl DirFs {
    /// Serves `root`, which must be a directory.
    pub fn new(root: &Path) -> io::Result<Self> {
        let root = root
            .canonicalize()
            .map_err(|e| io::Error::new(e.kind(), format!("{}: {e}", root.display())))?;
        if !root.is_dir() {
            return Err(io::Error::other(format!(
                "{}: not a directory",
                root.display()
            )));
        }
        Ok(Self {
            root,
            open: HashMap::new(),
        })
    }

    /// The local path of `path`, if it stays below the root. For a path that does not exist
    /// yet, its directory must.
    fn resolve(&self, path: &str) -> Result<PathBuf, Nak> {
        let mut local = self.root.clone();
        for c in Path::new(path.trim_start_matches('/')).components() {
            match c {
                Component::Normal(part) => local.push(part),
                Component::CurDir => {}
                _ => return Err(Nak::FileProtected),
            }
        }
        let real = match local.canonicalize() {
            Ok(real) => real,
            Err(_) => {
                let parent = local.parent().ok_or(Nak::FileNotFound)?;
                let name = local.file_name().ok_or(Nak::FileNotFound)?;
                parent
                    .canonicalize()
                    .map_err(|_| Nak::FileNotFound)?
                    .join(name)
            }
        };
        if real.starts_with(&self.root) {
            Ok(real)
        } else {
            Err(Nak::FileProtected)
        }
    }
}

fn nak(e: &io::Error) -> Nak {
    match e.kind() {
        io::ErrorKind::NotFound => Nak::FileNotFound,
        io::ErrorKind::AlreadyExists => Nak::FileExists,
        io::ErrorKind::PermissionDenied => Nak::FileProtected,
        _ => e
            .raw_os_error()
            .and_then(|n| u8::try_from(n).ok())
            .map_or(Nak::Fail, Nak::FailErrno),
    }
}

impl FileSystem for DirFs {
    fn list(
        &mut self,
        path: &str,
        from: u32,
        out: &mut dyn FnMut(Entry<'_>) -> bool,
    ) -> Result<(), Nak> {
        let dir = self.resolve(path)?;
        let mut names: Vec<_> = fs::read_dir(&dir)
            .map_err(|e| nak(&e))?
            .flatten()
            .map(|e| e.file_name())
            .collect();
        names.sort();
        for name in names.iter().skip(from as usize) {
            let meta = fs::metadata(dir.join(name));
            let text = name.to_str();
            let (kind, size) = match (&meta, text) {
                (Ok(m), Some(_)) if m.is_file() => {
                    (EntryKind::File, m.len().min(u32::MAX.into()) as u32)
                }
                (Ok(m), Some(_)) if m.is_dir() => (EntryKind::Dir, 0),
                _ => (EntryKind::Skip, 0),
            };
            let name = text.unwrap_or("");
            if !out(Entry { kind, name, size }) {
                break;
            }
        }
        Ok(())
    }

    fn open_read(&mut self, session: u8, path: &str) -> Result<u32, Nak> {
        let file = File::open(self.resolve(path)?).map_err(|e| nak(&e))?;
        let meta = file.metadata().map_err(|e| nak(&e))?;
        if !meta.is_file() {
            return Err(Nak::Fail);
        }
        let size = u32::try_from(meta.len()).map_err(|_| Nak::Fail)?;
        self.open.insert(session, (file, false));
        Ok(size)
    }

    fn open_write(&mut self, session: u8, path: &str, create: bool) -> Result<u32, Nak> {
        let local = self.resolve(path)?;
        let file = OpenOptions::new()
            .write(true)
            .create(create)
            .truncate(create)
            .open(local)
            .map_err(|e| nak(&e))?;
        let size = file.metadata().map_err(|e| nak(&e))?.len();
        self.open.insert(session, (file, true));
        u32::try_from(size).map_err(|_| Nak::Fail)
    }

    fn read(&mut self, session: u8, offset: u32, buf: &mut [u8]) -> Result<usize, Nak> {
        let (file, _) = self.open.get_mut(&session).ok_or(Nak::InvalidSession)?;
        file.seek(SeekFrom::Start(offset.into()))
            .map_err(|e| nak(&e))?;
        let mut n = 0;
        while n < buf.len() {
            match file.read(&mut buf[n..]) {
                Ok(0) => break,
                Ok(k) => n += k,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(nak(&e)),
            }
        }
        Ok(n)
    }

    fn write(&mut self, session: u8, offset: u32, data: &[u8]) -> Result<(), Nak> {
        let (file, writable) = self.open.get_mut(&session).ok_or(Nak::InvalidSession)?;
        if !*writable {
            return Err(Nak::InvalidSession);
        }
        file.seek(SeekFrom::Start(offset.into()))
            .map_err(|e| nak(&e))?;
        file.write_all(data).map_err(|e| nak(&e))
    }

    fn close(&mut self, session: u8) {
        self.open.remove(&session);
    }

    fn remove_file(&mut self, path: &str) -> Result<(), Nak> {
        fs::remove_file(self.resolve(path)?).map_err(|e| nak(&e))
    }

    fn create_dir(&mut self, path: &str) -> Result<(), Nak> {
        fs::create_dir(self.resolve(path)?).map_err(|e| nak(&e))
    }

    fn remove_dir(&mut self, path: &str) -> Result<(), Nak> {
        let local = self.resolve(path)?;
        if local == self.root {
            return Err(Nak::FileProtected);
        }
        fs::remove_dir(local).map_err(|e| nak(&e))
    }

    fn rename(&mut self, from: &str, to: &str) -> Result<(), Nak> {
        fs::rename(self.resolve(from)?, self.resolve(to)?).map_err(|e| nak(&e))
    }

    fn truncate(&mut self, path: &str, len: u32) -> Result<(), Nak> {
        let file = OpenOptions::new()
            .write(true)
            .open(self.resolve(path)?)
            .map_err(|e| nak(&e))?;
        file.set_len(len.into()).map_err(|e| nak(&e))
    }
}

/// A directory entry as [`Remote::ftp_list`] returns it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ListEntry {
    /// File or directory (skipped entries are left out).
    pub kind: EntryKind,
    /// Its name.
    pub name: String,
    /// A file's size.
    pub size: u32,
}

fn io_error(e: ftp::Error) -> io::Error {
    let kind = match e {
        ftp::Error::Timeout => io::ErrorKind::TimedOut,
        ftp::Error::Nak(Nak::FileNotFound) => io::ErrorKind::NotFound,
        ftp::Error::Nak(Nak::FileExists) => io::ErrorKind::AlreadyExists,
        ftp::Error::Nak(Nak::FileProtected) => io::ErrorKind::PermissionDenied,
        ftp::Error::PathTooLong => io::ErrorKind::InvalidInput,
        _ => io::ErrorKind::Other,
    };
    io::Error::new(kind, e.to_string())
}

impl Remote<'_> {
    /// A client for one operation, numbering its requests on from the last one's.
    fn ftp_client(&self) -> ftp::Client {
        ftp::Client::new(self.ftp_config, self.target().address).with_seq(self.ftp_seq)
    }

    /// Runs an FTP operation to its end; `on` sees each event, `progress` each change of
    /// (bytes transferred, size) while reading or writing. Uploads take their bytes from
    /// `source`.
    async fn run_ftp(
        &mut self,
        wait: &impl Wait,
        client: &mut ftp::Client,
        source: &mut [u8],
        mut on: impl FnMut(&ftp::Event),
        mut progress: impl FnMut(u32, u32),
    ) -> io::Result<Option<u32>> {
        let mut shown = (0, 0);
        loop {
            let now = self.now_us();
            while let Some(m) = client.poll_transmit(now, source) {
                self.send(&m)?;
            }
            while let Some(e) = client.poll_event() {
                on(&e);
                if let ftp::Event::Done(result) = e {
                    // A session closed after a failure: its TerminateSession goes out.
                    while let Some(m) = client.poll_transmit(now, source) {
                        self.send(&m)?;
                    }
                    self.ftp_seq = client.seq();
                    let value = result.map_err(io_error)?;
                    if shown.1 > 0 {
                        progress(shown.1, shown.1);
                    }
                    return Ok(value);
                }
            }
            let now_progress = client.progress();
            if now_progress != shown && now_progress.1 > 0 {
                shown = now_progress;
                progress(shown.0, shown.1);
            }
            let until = client
                .poll_timeout()
                .unwrap_or(now + 1_000_000)
                .max(now + 1);
            if let Some((from, msg)) = self.next(wait, until).await? {
                client.handle(self.now_us(), from, &msg);
            }
        }
    }

    /// The entries of directory `path` on the target, in its order.
    pub fn ftp_list(&mut self, path: &str) -> io::Result<Vec<ListEntry>> {
        block_on(self.ftp_list_with(&Blocking, path))
    }

    /// [`Remote::ftp_list`], waiting with `wait`.
    pub async fn ftp_list_with(
        &mut self,
        wait: &impl Wait,
        path: &str,
    ) -> io::Result<Vec<ListEntry>> {
        let mut client = self.ftp_client();
        let _ = client.list(self.now_us(), path);
        let mut out = Vec::new();
        let on = |e: &ftp::Event| {
            if let ftp::Event::Listing(chunk) = e {
                out.extend(
                    entries(chunk.as_slice())
                        .filter(|e| e.kind != EntryKind::Skip)
                        .map(|e| ListEntry {
                            kind: e.kind,
                            name: e.name.to_string(),
                            size: e.size,
                        }),
                );
            }
        };
        self.run_ftp(wait, &mut client, &mut [], on, |_, _| {})
            .await?;
        Ok(out)
    }

    /// Reads file `path` from the target; `progress` sees (bytes received, size).
    pub fn ftp_get(&mut self, path: &str, progress: impl FnMut(u32, u32)) -> io::Result<Vec<u8>> {
        block_on(self.ftp_get_with(&Blocking, path, progress))
    }

    /// [`Remote::ftp_get`], waiting with `wait`.
    pub async fn ftp_get_with(
        &mut self,
        wait: &impl Wait,
        path: &str,
        progress: impl FnMut(u32, u32),
    ) -> io::Result<Vec<u8>> {
        let mut client = self.ftp_client();
        let _ = client.read(self.now_us(), path);
        let mut data = Vec::new();
        let on = |e: &ftp::Event| match e {
            ftp::Event::Size(size) => data = vec![0; *size as usize],
            ftp::Event::Data { offset, bytes } => {
                let b = bytes.as_slice();
                let at = *offset as usize;
                if let Some(dst) = data.get_mut(at..at + b.len()) {
                    dst.copy_from_slice(b);
                }
            }
            _ => {}
        };
        self.run_ftp(wait, &mut client, &mut [], on, progress)
            .await?;
        Ok(data)
    }

    /// Writes `data` to file `path` on the target (created, or emptied first); `progress` sees
    /// (bytes acknowledged, size).
    pub fn ftp_put(
        &mut self,
        path: &str,
        data: &[u8],
        progress: impl FnMut(u32, u32),
    ) -> io::Result<()> {
        block_on(self.ftp_put_with(&Blocking, path, data, progress))
    }

    /// [`Remote::ftp_put`], waiting with `wait`.
    pub async fn ftp_put_with(
        &mut self,
        wait: &impl Wait,
        path: &str,
        data: &[u8],
        progress: impl FnMut(u32, u32),
    ) -> io::Result<()> {
        let size = u32::try_from(data.len())
            .map_err(|_| io::Error::other("a file over 4 GiB cannot go over MAVLink FTP"))?;
        let mut client = self.ftp_client();
        let _ = client.write(self.now_us(), path, size);
        let mut source = data.to_vec();
        self.run_ftp(wait, &mut client, &mut source, |_| {}, progress)
            .await
            .map(drop)
    }

    /// The CRC-32 of file `path` on the target, as the target computes it.
    pub fn ftp_crc32(&mut self, path: &str) -> io::Result<u32> {
        block_on(self.ftp_crc32_with(&Blocking, path))
    }

    /// [`Remote::ftp_crc32`], waiting with `wait`.
    pub async fn ftp_crc32_with(&mut self, wait: &impl Wait, path: &str) -> io::Result<u32> {
        let mut client = self.ftp_client();
        let _ = client.crc32(self.now_us(), path);
        let crc = self
            .run_ftp(wait, &mut client, &mut [], |_| {}, |_, _| {})
            .await?;
        crc.ok_or_else(|| io::Error::other("the CRC-32 reply held no value"))
    }

    /// Removes file `path` on the target.
    pub fn ftp_remove(&mut self, path: &str) -> io::Result<()> {
        block_on(self.ftp_remove_with(&Blocking, path))
    }

    /// [`Remote::ftp_remove`], waiting with `wait`.
    pub async fn ftp_remove_with(&mut self, wait: &impl Wait, path: &str) -> io::Result<()> {
        let now = self.now_us();
        self.ftp_simple(wait, |c| c.remove(now, path)).await
    }

    /// Creates directory `path` on the target.
    pub fn ftp_mkdir(&mut self, path: &str) -> io::Result<()> {
        block_on(self.ftp_mkdir_with(&Blocking, path))
    }

    /// [`Remote::ftp_mkdir`], waiting with `wait`.
    pub async fn ftp_mkdir_with(&mut self, wait: &impl Wait, path: &str) -> io::Result<()> {
        let now = self.now_us();
        self.ftp_simple(wait, |c| c.create_dir(now, path)).await
    }

    /// Removes directory `path` (empty) on the target.
    pub fn ftp_rmdir(&mut self, path: &str) -> io::Result<()> {
        block_on(self.ftp_rmdir_with(&Blocking, path))
    }

    /// [`Remote::ftp_rmdir`], waiting with `wait`.
    pub async fn ftp_rmdir_with(&mut self, wait: &impl Wait, path: &str) -> io::Result<()> {
        let now = self.now_us();
        self.ftp_simple(wait, |c| c.remove_dir(now, path)).await
    }

    /// Renames `from` to `to` on the target.
    pub fn ftp_rename(&mut self, from: &str, to: &str) -> io::Result<()> {
        block_on(self.ftp_rename_with(&Blocking, from, to))
    }

    /// [`Remote::ftp_rename`], waiting with `wait`.
    pub async fn ftp_rename_with(
        &mut self,
        wait: &impl Wait,
        from: &str,
        to: &str,
    ) -> io::Result<()> {
        let now = self.now_us();
        self.ftp_simple(wait, |c| c.rename(now, from, to)).await
    }

    /// Runs an operation of one request and its answer, started by `start`.
    async fn ftp_simple(
        &mut self,
        wait: &impl Wait,
        start: impl FnOnce(&mut ftp::Client) -> Result<(), ferrolink_runtime::mavlink::service::Busy>,
    ) -> io::Result<()> {
        let mut client = self.ftp_client();
        let _ = start(&mut client);
        self.run_ftp(wait, &mut client, &mut [], |_| {}, |_, _| {})
            .await
            .map(drop)
    }
}
