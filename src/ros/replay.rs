//! Replay of a bag written by `run --record`: its input messages (arm commands, MTM and
//! console topics) drive the arms again, each applied at the frame start at which the
//! recording node applied it (its log time is that frame's simulated start time). Same
//! scene, same inputs at the same frames: on the CPU backend the tissue outputs repeat bit for
//! bit.
//!
//! The bag must come from this scene and namespace: every topic in it must be one of the
//! scene's input or output topics, and at least one input must be there.

use std::collections::{BTreeSet, VecDeque};
use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};

use crate::config::Scene;
use crate::ros::inputs::{input_topics, InputTopic};
use crate::ros::msgs::CdrError;
use crate::ros::outputs::OutputLayout;
use crate::sim::input::ReplayInput;
use crate::sim::RecordedInput;

/// The inputs of a bag, in the order they were applied.
#[derive(Clone, Debug)]
pub struct Replay {
    /// The bag's input messages as simulation inputs, in log-time order.
    pub inputs: VecDeque<ReplayInput>,
    /// Simulated time of the bag's last message (s): a replay runs this long.
    pub end: f64,
    /// Messages in the bag, inputs and outputs.
    pub messages: u64,
}

#[derive(Debug, thiserror::Error)]
/// Why a bag cannot be replayed on a scene.
pub enum ReplayError {
    #[error("cannot open {path}: {source}")]
    /// The file cannot be opened.
    Open {
        /// The bag's path.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    #[error(
        "{} was never finished (its run was killed, or lost power): \
         `dvrk-tissue-sim bag recover {} OUT.mcap` rebuilds a readable bag from its completed \
         chunks; replay that ({source})", path.display(), path.display()
    )]
    /// The bag was never finished (no summary); `bag recover` rebuilds it.
    Unfinished {
        /// The bag's path.
        path: PathBuf,
        /// The MCAP reader's error.
        source: mcap::McapError,
    },
    #[error("{path} is not a readable MCAP file: {source}")]
    /// The file is not readable MCAP.
    Corrupt {
        /// The bag's path.
        path: PathBuf,
        /// The MCAP reader's error.
        source: mcap::McapError,
    },
    #[error(
        "{path} was not recorded on this scene ({scene}; namespace {namespace}): \
         topic(s) {topics} are not among its inputs and outputs"
    )]
    /// The bag has topics that are neither inputs nor outputs of this scene.
    OtherScene {
        /// The bag's path.
        path: PathBuf,
        /// The scene's name.
        scene: String,
        /// The namespace the topics were resolved under.
        namespace: String,
        /// The foreign topics, comma separated.
        topics: String,
    },
    #[error(
        "{path} has no input messages on this scene's input topics ({topics}): \
         nothing to drive the arms with"
    )]
    /// The bag has no message on any of the scene's input topics.
    NoInputs {
        /// The bag's path.
        path: PathBuf,
        /// The scene's input topics, comma separated.
        topics: String,
    },
    #[error("{path}: message {index} on {topic}: {message}")]
    /// One input message cannot be used.
    Message {
        /// The bag's path.
        path: PathBuf,
        /// The message's position in the bag, from 0.
        index: u64,
        /// The message's topic.
        topic: String,
        /// What is wrong with it.
        message: MessageError,
    },
}

/// What is wrong with one input message of a bag.
#[derive(Debug, thiserror::Error)]
pub enum MessageError {
    #[error("type {found}, expected {expected}")]
    /// The channel's schema is not the topic's ROS type.
    Type {
        /// The schema name in the bag (`(no schema)` when absent).
        found: String,
        /// The topic's ROS type, `pkg/msg/Type`.
        expected: String,
    },
    #[error("message encoding {0}, expected cdr")]
    /// A message encoding other than `cdr` (holds the encoding).
    Encoding(String),
    #[error(transparent)]
    /// The CDR payload does not decode.
    Cdr(#[from] CdrError),
}

/// Reads the inputs of the bag at `path` for `scene` under `namespace`.
pub fn load(
    path: &Path,
    scene: &Scene,
    layout: &OutputLayout,
    namespace: &str,
) -> Result<Replay, ReplayError> {
    let open = |source| ReplayError::Open {
        path: path.to_owned(),
        source,
    };
    let file = File::open(path).map_err(open)?;
    let options = crate::ros::recover::reader_options(file.metadata().map_err(open)?.len());
    let inputs_of_scene: Vec<InputTopic> = input_topics(scene, namespace);
    let outputs_of_scene: BTreeSet<String> = layout
        .topics()
        .into_iter()
        .map(|(topic, _)| topic)
        .collect();
    let mut unknown = BTreeSet::new();
    let mut inputs = VecDeque::new();
    let mut end = 0u64;
    let mut messages = 0u64;
    for (index, message) in
        mcap::io::MessageReader::new_with_options(BufReader::new(file), options).enumerate()
    {
        let message = message.map_err(|source| {
            if crate::ros::recover::is_unfinished(path).unwrap_or(false) {
                ReplayError::Unfinished {
                    path: path.to_owned(),
                    source,
                }
            } else {
                ReplayError::Corrupt {
                    path: path.to_owned(),
                    source,
                }
            }
        })?;
        messages += 1;
        end = end.max(message.log_time);
        let topic = &message.channel.topic;
        let Some(input) = inputs_of_scene.iter().find(|t| &t.topic == topic) else {
            if !outputs_of_scene.contains(topic) {
                unknown.insert(topic.clone());
            }
            continue;
        };
        let fail = |m: MessageError| ReplayError::Message {
            path: path.to_owned(),
            index: index as u64,
            topic: topic.clone(),
            message: m,
        };
        let type_name = input.kind.type_name();
        let schema = message.channel.schema.as_ref().map(|s| s.name.as_str());
        if schema != Some(type_name.as_str()) {
            return Err(fail(MessageError::Type {
                found: schema.unwrap_or("(no schema)").to_owned(),
                expected: type_name,
            }));
        }
        if message.channel.message_encoding != "cdr" {
            return Err(fail(MessageError::Encoding(
                message.channel.message_encoding.clone(),
            )));
        }
        let decoded = input
            .kind
            .decode(&message.data)
            .map_err(|e| fail(e.into()))?;
        // A message the node rejected before the simulation (a Joy without buttons) has no
        // effect either way.
        let sim_input = input.to_sim_input(decoded).unwrap_or(None);
        inputs.push_back(ReplayInput {
            time: message.log_time,
            input: sim_input,
            record: RecordedInput {
                topic: topic.clone(),
                type_name,
                cdr: message.data.into_owned(),
            },
        });
    }
    if !unknown.is_empty() {
        let arms: Vec<&str> = scene.arms.iter().map(|a| a.name.as_str()).collect();
        return Err(ReplayError::OtherScene {
            path: path.to_owned(),
            scene: format!("\"{}\", arms {}", scene.name, arms.join(", ")),
            namespace: namespace.to_owned(),
            topics: unknown.into_iter().take(5).collect::<Vec<_>>().join(", "),
        });
    }
    if inputs.is_empty() {
        return Err(ReplayError::NoInputs {
            path: path.to_owned(),
            topics: inputs_of_scene
                .iter()
                .map(|t| t.topic.as_str())
                .take(4)
                .collect::<Vec<_>>()
                .join(", ")
                + ", ...",
        });
    }
    Ok(Replay {
        inputs,
        end: end as f64 * 1e-9,
        messages,
    })
}
