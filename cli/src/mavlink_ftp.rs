//! `ferrolink mavlink ftp ls|get|put|mkdir|rmdir|rm|mv|crc`: files on a vehicle over MAVLink
//! FTP.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::Subcommand;
use ferrolink_io::mavlink::services::Remote;
use ferrolink_runtime::crc::FTP_CRC32;
use ferrolink_runtime::mavlink::service::ftp::EntryKind;

use crate::mavlink_services::{connect, progress_bar, Result, TargetArg};

#[derive(Subcommand)]
pub enum FtpCommand {
    /// List a directory: one JSON line per entry, `{"name": "...", "kind": "file"|"dir",
    /// "size": N}`, in the vehicle's order.
    Ls {
        /// The connection: udpin://, udpout://, tcpin://, tcpout://, serial://.
        uri: String,
        /// The directory on the vehicle.
        path: String,
        #[command(flatten)]
        target: TargetArg,
    },
    /// Read a file from the vehicle (burst reads, lost data read again by offset). LOCAL `-`
    /// is stdout; otherwise LOCAL appears only once the whole file is in.
    Get {
        /// The connection.
        uri: String,
        /// The file on the vehicle.
        remote: String,
        /// Where to write it.
        local: PathBuf,
        #[command(flatten)]
        target: TargetArg,
    },
    /// Create a directory on the vehicle. Prints nothing; exit 1 with the vehicle's error.
    Mkdir {
        /// The connection.
        uri: String,
        /// The directory to create.
        path: String,
        #[command(flatten)]
        target: TargetArg,
    },
    /// Remove an empty directory on the vehicle. Prints nothing; exit 1 with the vehicle's
    /// error.
    Rmdir {
        /// The connection.
        uri: String,
        /// The directory to remove.
        path: String,
        #[command(flatten)]
        target: TargetArg,
    },
    /// Remove a file on the vehicle. Prints nothing; exit 1 with the vehicle's error.
    Rm {
        /// The connection.
        uri: String,
        /// The file to remove.
        path: String,
        #[command(flatten)]
        target: TargetArg,
    },
    /// Rename a file or directory on the vehicle. Prints nothing; exit 1 with the vehicle's
    /// error.
    Mv {
        /// The connection.
        uri: String,
        /// Its path now.
        from: String,
        /// Its new path.
        to: String,
        #[command(flatten)]
        target: TargetArg,
    },
    /// Print the vehicle's CRC-32 of a file: `{"path": "...", "crc32": N}`.
    Crc {
        /// The connection.
        uri: String,
        /// The file.
        path: String,
        #[command(flatten)]
        target: TargetArg,
    },
    /// Write a file to the vehicle (created, or emptied first), then check the vehicle's
    /// CRC-32 of it against ours when the vehicle computes one.
    Put {
        /// The connection.
        uri: String,
        /// The file to send.
        local: PathBuf,
        /// Where on the vehicle.
        remote: String,
        #[command(flatten)]
        target: TargetArg,
    },
}

pub fn ftp(command: FtpCommand) -> Result<ExitCode> {
    // The one-request operations print nothing on success and the server's error on failure.
    let simple = |uri: &str,
                  target: &TargetArg,
                  what: String,
                  op: &dyn Fn(&mut Remote) -> std::io::Result<()>|
     -> Result<ExitCode> {
        let (mut link, peer) = connect(uri, target)?;
        match op(&mut Remote::new(&mut link, peer)) {
            Ok(()) => Ok(ExitCode::SUCCESS),
            Err(e) => {
                eprintln!("{what}: {e}");
                Ok(ExitCode::FAILURE)
            }
        }
    };
    match command {
        FtpCommand::Mkdir { uri, path, target } => {
            simple(&uri, &target, format!("mkdir {path}"), &|r| {
                r.ftp_mkdir(&path)
            })
        }
        FtpCommand::Rmdir { uri, path, target } => {
            simple(&uri, &target, format!("rmdir {path}"), &|r| {
                r.ftp_rmdir(&path)
            })
        }
        FtpCommand::Rm { uri, path, target } => simple(&uri, &target, format!("rm {path}"), &|r| {
            r.ftp_remove(&path)
        }),
        FtpCommand::Mv {
            uri,
            from,
            to,
            target,
        } => simple(&uri, &target, format!("mv {from} {to}"), &|r| {
            r.ftp_rename(&from, &to)
        }),
        FtpCommand::Crc { uri, path, target } => {
            let (mut link, peer) = connect(&uri, &target)?;
            match Remote::new(&mut link, peer).ftp_crc32(&path) {
                Ok(crc) => {
                    let path = serde_json::to_string(&path)?;
                    println!(r#"{{"path": {path}, "crc32": {crc}}}"#);
                    Ok(ExitCode::SUCCESS)
                }
                Err(e) => {
                    eprintln!("crc {path}: {e}");
                    Ok(ExitCode::FAILURE)
                }
            }
        }
        FtpCommand::Ls { uri, path, target } => {
            let (mut link, peer) = connect(&uri, &target)?;
            let entries = Remote::new(&mut link, peer)
                .ftp_list(&path)
                .map_err(|e| format!("ls {path}: {e}"))?;
            let mut out = std::io::stdout().lock();
            for e in entries {
                let kind = if e.kind == EntryKind::Dir {
                    "dir"
                } else {
                    "file"
                };
                let line = format!(
                    "{{\"name\": {}, \"kind\": \"{kind}\", \"size\": {}}}",
                    serde_json::json!(e.name),
                    e.size
                );
                if writeln!(out, "{line}").is_err() {
                    break;
                }
            }
            Ok(ExitCode::SUCCESS)
        }
        FtpCommand::Get {
            uri,
            remote,
            local,
            target,
        } => {
            let (mut link, peer) = connect(&uri, &target)?;
            let bar = progress_bar("get");
            let data = Remote::new(&mut link, peer)
                .ftp_get(&remote, |done, size| {
                    bar.set_length(size.into());
                    bar.set_position(done.into());
                })
                .map_err(|e| format!("get {remote}: {e}"))?;
            bar.finish_and_clear();
            if local == Path::new("-") {
                std::io::stdout().lock().write_all(&data)?;
            } else {
                write_whole(&local, &data)?;
            }
            Ok(ExitCode::SUCCESS)
        }
        FtpCommand::Put {
            uri,
            local,
            remote,
            target,
        } => {
            let data = std::fs::read(&local).map_err(|e| format!("{}: {e}", local.display()))?;
            let (mut link, peer) = connect(&uri, &target)?;
            let mut vehicle = Remote::new(&mut link, peer);
            let bar = progress_bar("put");
            vehicle
                .ftp_put(&remote, &data, |done, size| {
                    bar.set_length(size.into());
                    bar.set_position(done.into());
                })
                .map_err(|e| format!("put {remote}: {e}"))?;
            bar.finish_and_clear();
            match vehicle.ftp_crc32(&remote) {
                Ok(crc) if crc != FTP_CRC32.checksum(&data) => {
                    eprintln!(
                        "put {remote}: the vehicle's CRC-32 {crc:#010x} is not the file's {:#010x}",
                        FTP_CRC32.checksum(&data)
                    );
                    Ok(ExitCode::FAILURE)
                }
                // A vehicle without CRC-32 (or one that failed it) had every write
                // acknowledged; that stands.
                _ => Ok(ExitCode::SUCCESS),
            }
        }
    }
}

/// Writes `data` to `path` through a temporary file beside it, so that `path` is either the
/// old file or the whole new one.
fn write_whole(path: &Path, data: &[u8]) -> Result<()> {
    let name = path
        .file_name()
        .ok_or_else(|| format!("{}: not a file name", path.display()))?;
    let mut tmp_name = std::ffi::OsString::from(".");
    tmp_name.push(name);
    tmp_name.push(".part");
    let tmp = path.with_file_name(tmp_name);
    std::fs::write(&tmp, data).map_err(|e| format!("{}: {e}", tmp.display()))?;
    std::fs::rename(&tmp, path).map_err(|e| format!("{}: {e}", path.display()).into())
}
