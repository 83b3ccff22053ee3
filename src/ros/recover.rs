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
    #[error("{} already exists: choose another output file", path.display())]
    /// The output file exists already (recovery never overwrites).
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

/// Copies every readable message of `input` into a new finished bag at `output` (which
/// must not exist yet).
pub fn recover(input: &Path, output: &Path) -> Result<Recovered, RecoverError> {
    let open = |source| RecoverError::Open {
        path: input.to_owned(),
        source,
    };
    let mut file = File::open(input).map_err(open)?;
    let profile =
        header_profile(&mut file)
            .map_err(open)?
            .ok_or_else(|| RecoverError::NotMcap {
                path: input.to_owned(),
            })?;
    if output.exists() {
        return Err(RecoverError::Exists {
            path: output.to_owned(),
        });
    }
    let out = File::create(output).map_err(|source| RecoverError::Create {
        path: output.to_owned(),
        source,
    })?;
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
        .create(BufWriter::with_capacity(1 << 20, out))
        .map_err(write)?;
    let mut recovered = Recovered {
        messages: 0,
        topics: 0,
        end: 0.0,
        stopped: None,
    };
    let mut topics = std::collections::BTreeSet::new();
    // An unfinished file has no closing magic; its cut-off chunk ends the reading.
    let options = LinearReaderOptions::default().with_skip_end_magic(true);
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
    Ok(recovered)
}
