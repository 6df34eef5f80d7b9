//! Reading logs back (`hardbody inspect`, resuming, tests): complete logs
//! and logs cut off mid-write, up to their last complete record.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::{FailureRecord, LogError, StateRecord, Stats};

/// What a log holds.
#[derive(Debug, Clone, PartialEq)]
pub struct LogContents {
    /// The `hardbody` metadata record (version, scene text, log time).
    pub metadata: BTreeMap<String, String>,
    /// Messages per topic.
    pub counts: BTreeMap<String, u64>,
    /// Every `/stats` message, with its log time.
    pub stats: Vec<(u64, Stats)>,
    /// The last complete `/state`, with its log time.
    pub last_state: Option<(u64, StateRecord)>,
    /// Every `/state` (only when asked for).
    pub states: Vec<(u64, StateRecord)>,
    /// Why the run failed, if it did (`/failure`).
    pub failure: Option<(u64, FailureRecord)>,
    /// Whether the file ended before the MCAP footer (a killed run); it is
    /// read up to its last complete record.
    pub truncated: bool,
}

impl LogContents {
    /// The scene text the log was written from.
    pub fn scene_text(&self) -> Option<&str> {
        self.metadata.get("scene").map(String::as_str)
    }
}

/// Reads `path`; with `all_states`, keeps every `/state` (else the last).
pub fn read_log(path: &Path, all_states: bool) -> Result<LogContents, LogError> {
    let buf = std::fs::read(path).map_err(|source| LogError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let content = |message: String| LogError::Content {
        path: PathBuf::from(path),
        message,
    };
    if !buf.starts_with(mcap::MAGIC) {
        return Err(content(
            "not an MCAP file (no MCAP magic at the start)".into(),
        ));
    }
    let mut contents = LogContents {
        metadata: BTreeMap::new(),
        counts: BTreeMap::new(),
        stats: Vec::new(),
        last_state: None,
        states: Vec::new(),
        failure: None,
        truncated: false,
    };
    // Metadata and the end of the data, record by record.
    for record in
        mcap::read::LinearReader::new_with_options(&buf, mcap::read::Options::IgnoreEndMagic.into())
            .map_err(|e| content(e.to_string()))?
    {
        match record {
            Ok(mcap::records::Record::Metadata(m)) if m.name == "hardbody" => {
                contents.metadata = m.metadata;
            }
            Ok(_) => {}
            Err(_) => {
                contents.truncated = true;
                break;
            }
        }
    }
    let stream =
        mcap::MessageStream::new_with_options(&buf, mcap::read::Options::IgnoreEndMagic.into())
            .map_err(|e| content(e.to_string()))?;
    for message in stream {
        let Ok(m) = message else {
            contents.truncated = true;
            break;
        };
        let topic = m.channel.topic.clone();
        *contents.counts.entry(topic.clone()).or_default() += 1;
        match topic.as_str() {
            "/stats" => {
                let s: Stats = serde_json::from_slice(&m.data)
                    .map_err(|e| content(format!("/stats message {}: {e}", m.sequence)))?;
                contents.stats.push((m.log_time, s));
            }
            "/state" => {
                let s: StateRecord = serde_json::from_slice(&m.data)
                    .map_err(|e| content(format!("/state message {}: {e}", m.sequence)))?;
                if all_states {
                    contents.states.push((m.log_time, s.clone()));
                }
                contents.last_state = Some((m.log_time, s));
            }
            "/failure" => {
                let f: FailureRecord = serde_json::from_slice(&m.data)
                    .map_err(|e| content(format!("/failure message {}: {e}", m.sequence)))?;
                contents.failure = Some((m.log_time, f));
            }
            _ => {}
        }
    }
    if !buf.ends_with(mcap::MAGIC) {
        contents.truncated = true;
    }
    if contents.metadata.is_empty() {
        return Err(content(
            "not a hardbody log (no hardbody metadata record)".into(),
        ));
    }
    Ok(contents)
}

/// One message as stored: topic, log time, bytes.
pub type RawMessage = (String, u64, Vec<u8>);

/// Every complete message of `path`, in file order (what a resumed run
/// copies from the interrupted one).
pub fn read_messages(path: &Path) -> Result<Vec<RawMessage>, LogError> {
    let buf = std::fs::read(path).map_err(|source| LogError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let stream =
        mcap::MessageStream::new_with_options(&buf, mcap::read::Options::IgnoreEndMagic.into())
            .map_err(|e| LogError::Content {
                path: path.to_path_buf(),
                message: e.to_string(),
            })?;
    Ok(stream
        .map_while(Result::ok)
        .map(|m| (m.channel.topic.clone(), m.log_time, m.data.into_owned()))
        .collect())
}
