//! `bag recover`: a finished, indexed bag rebuilt from one whose writer never finished it (a
//! killed process, a power loss). Such a file has no summary, no footer and no closing magic,
//! and its last chunk may be cut off; standard readers refuse it. Every message of its
//! completed chunks is copied, with its channel, schema, sequence and times, into a new file
//! that every reader opens; reading stops at the first record that is cut off or damaged.

use std::fs::File;
use std::io::{BufReader, BufWriter, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use mcap::sans_io::LinearReaderOptions;

/// What [`recover`] copied.
#[derive(Clone, Debug)]
pub struct Recovered {
    /// Messages copied to the output.
    pub messages: u64,
    /// Topics (channels) in the output.
    pub topics: usize,
    /// Log time of the last message copied (s).
    pub end: f64,
    /// Why reading the input stopped before its end (`None`: it was read to the end).
    pub stopped: Option<String>,
}

#[derive(Debug, thiserror::Error)]
/// Why an unfinished bag could not be recovered.
pub enum RecoverError {
    #[error("cannot open {}: {source}", path.display())]
    /// The input cannot be opened.
    Open {
        /// The input's path.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    #[error("{} is not an MCAP file (no MCAP header at its start)", path.display())]
    /// The input does not start with the MCAP magic.
    NotMcap {
        /// The input's path.
        path: PathBuf,
    },
    #[error("{} already exists: choose another output file, or pass --force to replace it", path.display())]
    /// The output file exists already (replaced only with `--force`).
    Exists {
        /// The output's path.
        path: PathBuf,
    },
    #[error("cannot create {}: {}", path.display(), crate::ros::recorder::io_cause(source, path))]
    /// The output cannot be created.
    Create {
        /// The output's path.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    #[error("writing {}: {source}", path.display())]
    /// Writing the output failed.
    Write {
        /// The output's path.
        path: PathBuf,
        /// The MCAP writer's error.
        source: mcap::McapError,
    },
}

/// True when the file at `path` starts as an MCAP file but does not end with the closing
/// magic: its writer never finished it.
pub fn is_unfinished(path: &Path) -> std::io::Result<bool> {
    let mut file = File::open(path)?;
    let mut magic = [0u8; 8];
    if file.read_exact(&mut magic).is_err() || magic != mcap::MAGIC {
        return Ok(false);
    }
    if file.metadata()?.len() < 2 * mcap::MAGIC.len() as u64 {
        return Ok(true);
    }
    file.seek(SeekFrom::End(-(mcap::MAGIC.len() as i64)))?;
    file.read_exact(&mut magic)?;
    Ok(magic != mcap::MAGIC)
}

/// The profile named in an MCAP file's header (`ros2` for a rosbag2 bag), `None` when the
/// file does not start with an MCAP header.
fn header_profile(file: &mut File) -> std::io::Result<Option<String>> {
    let mut start = [0u8; 8 + 1 + 8 + 4];
    if file.read_exact(&mut start).is_err() || &start[..8] != mcap::MAGIC || start[8] != 0x01 {
        return Ok(None);
    }
    let record_len = u64::from_le_bytes(start[9..17].try_into().expect("8 bytes"));
    let profile_len = u32::from_le_bytes(start[17..21].try_into().expect("4 bytes")) as u64;
    if profile_len + 4 > record_len || profile_len > 1024 {
        return Ok(None);
    }
    let mut profile = vec![0u8; profile_len as usize];
    file.read_exact(&mut profile)?;
    file.seek(SeekFrom::Start(0))?;
    Ok(String::from_utf8(profile).ok())
}

/// How a bag reader bounds what a record may claim: a record cannot be longer than the file
/// holding it, so a length field beyond the file's size is refused before anything is
/// allocated for it (a hostile 61-byte file may claim 2⁶⁴ − 1 bytes). Chunks are checked
/// whole before they are decompressed, under the same bound.
pub fn reader_options(file_len: u64) -> LinearReaderOptions {
    LinearReaderOptions::default()
        .with_record_length_limit(usize::try_from(file_len).unwrap_or(usize::MAX))
        .with_prevalidate_chunk_crcs(true)
}

/// Copies every readable message of `input` into a new finished bag at `output`. The bag is
/// written under a temporary name beside `output` and renamed only when complete, so a
/// failure leaves nothing behind; `output` must not exist unless `replace` is set (and a
/// symlink there is replaced, never followed).
pub fn recover(input: &Path, output: &Path, replace: bool) -> Result<Recovered, RecoverError> {
    let open = |source| RecoverError::Open {
        path: input.to_owned(),
        source,
    };
    let mut file = File::open(input).map_err(open)?;
    let file_len = file.metadata().map_err(open)?.len();
    let profile =
        header_profile(&mut file)
            .map_err(open)?
            .ok_or_else(|| RecoverError::NotMcap {
                path: input.to_owned(),
            })?;
    if !replace && std::fs::symlink_metadata(output).is_ok() {
        return Err(RecoverError::Exists {
            path: output.to_owned(),
        });
    }
    let create = |source| RecoverError::Create {
        path: output.to_owned(),
        source,
    };
    let folder = match output.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let partial = tempfile::Builder::new()
        .prefix(".bag-recover-")
        .suffix(".mcap.partial")
        .tempfile_in(folder)
        .map_err(create)?;
    let write = |source| RecoverError::Write {
        path: output.to_owned(),
        source,
    };
    let mut writer = mcap::WriteOptions::new()
        .profile(profile)
        .library(concat!(
            "dvrk-tissue-sim ",
            env!("CARGO_PKG_VERSION"),
            " bag recover"
        ))
        .create(BufWriter::with_capacity(1 << 20, partial.as_file()))
        .map_err(write)?;
    let mut recovered = Recovered {
        messages: 0,
        topics: 0,
        end: 0.0,
        stopped: None,
    };
    let mut topics = std::collections::BTreeSet::new();
    // An unfinished file has no closing magic; its cut-off chunk ends the reading.
    let options = reader_options(file_len).with_skip_end_magic(true);
    for message in mcap::io::MessageReader::new_with_options(BufReader::new(file), options) {
        match message {
            Ok(message) => {
                writer.write(&message).map_err(write)?;
                recovered.messages += 1;
                recovered.end = recovered.end.max(message.log_time as f64 * 1e-9);
                if !topics.contains(&message.channel.topic) {
                    topics.insert(message.channel.topic.clone());
                }
            }
            Err(e) => {
                recovered.stopped = Some(e.to_string());
                break;
            }
        }
    }
    recovered.topics = topics.len();
    writer.finish().map_err(write)?;
    writer
        .into_inner()
        .flush()
        .map_err(|e| write(mcap::McapError::Io(e)))?;
    partial
        .as_file()
        .sync_all()
        .map_err(|e| write(mcap::McapError::Io(e)))?;
    let placed = if replace {
        partial.persist(output).map(|_| ())
    } else {
        partial.persist_noclobber(output).map(|_| ())
    };
    placed.map_err(|e| {
        if e.error.kind() == std::io::ErrorKind::AlreadyExists {
            RecoverError::Exists {
                path: output.to_owned(),
            }
        } else {
            create(e.error)
        }
    })?;
    Ok(recovered)
}
