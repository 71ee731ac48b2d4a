//! Checkpoints of a long identification run, and resuming from them.
//!
//! With [`IdentifyConfig::checkpoint`] set, [`identify`](crate::identify) saves the
//! run's full state every [`CheckpointConfig::every`] iterations and when it
//! stops: the current model, the history so far, the position of the
//! minibatch generator, the trust radius of the joint step, the failure
//! counters, and a fingerprint of the system, the data and the
//! configuration. [`identify_resume`](crate::identify_resume) continues from such a
//! file exactly where the run left off, so with the same seed the resumed
//! run's history equals an uninterrupted run's. A digest of the file's
//! content refuses a checkpoint edited since (a stop reason, best model or
//! generator position resumed as given would not continue the run).
//!
//! Files are written atomically (temporary file in the same directory,
//! flushed to disk, then renamed), so a crash or Ctrl-C while writing leaves
//! the previous checkpoint intact. Floating-point values round-trip exactly
//! through the JSON (serde_json's `float_roundtrip`).

use std::path::{Path, PathBuf};

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::config::{IdentifyConfig, IterationScheme};
use super::cost::Cost;
use super::history::{History, StopReason};
use super::state::RunState;
use crate::data::IdentificationData;
use crate::error::{Error, Result};
use crate::io::{read_capped, write_file, WriteMode};
use crate::model::known_parts::KnownParts;
use crate::model::{GramCertificate, Model};
use crate::system::MetriplecticSystem;

/// Where and how often [`identify`](crate::identify) saves checkpoints.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CheckpointConfig {
    /// The checkpoint file (replaced at every save). Its directory must
    /// exist, and a file already there must be a whole checkpoint: anything
    /// else, a damaged checkpoint included, is refused rather than
    /// overwritten.
    pub path: PathBuf,
    /// Save after every `every` iterations (and always when the run stops).
    pub every: usize,
}

impl CheckpointConfig {
    /// Checks that `every` is at least 1 and that `path` names a file in an
    /// existing directory, so a typo fails before hours of computation, and
    /// that a file already at `path` is a checkpoint (a run replaces its
    /// own kind of file, never the user's data or a model). A file that
    /// declares the checkpoint format but does not read as one (truncated,
    /// or a hand edit broke its JSON) is refused as a damaged checkpoint,
    /// with the parser's line and column: it may be worth repairing, so
    /// neither a new nor a resumed run replaces it.
    pub fn validate(&self) -> Result<()> {
        let invalid = |reason: String| Error::InvalidArgument {
            what: "checkpoint".to_owned(),
            reason,
        };
        if self.every == 0 {
            return Err(invalid("`every` must be at least 1".to_owned()));
        }
        if self.path.file_name().is_none() {
            return Err(invalid(format!(
                "{} does not name a file",
                self.path.display()
            )));
        }
        let directory = match self.path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        if !directory.is_dir() {
            return Err(invalid(format!(
                "directory {} of {} does not exist",
                directory.display(),
                self.path.display()
            )));
        }
        if self.path.is_dir() {
            return Err(invalid(format!("{} is a directory", self.path.display())));
        }
        if let Ok(meta) = std::fs::metadata(&self.path) {
            // An empty file (made in advance, e.g. by mktemp) holds nothing.
            let found = if meta.len() > 0 {
                examine(&self.path)
            } else {
                Existing::Checkpoint
            };
            match found {
                Existing::Checkpoint => {}
                // Perhaps a hand edit gone wrong: the user may want to
                // repair it, so neither a resumed nor a new run replaces it.
                Existing::Damaged(error) => {
                    return Err(invalid(format!(
                        "{} is a damaged checkpoint: it declares the checkpoint format but \
                         does not read as one ({error}); it is left as it is: repair it to \
                         resume from it, or move or delete it to start a new run at this path",
                        self.path.display()
                    )))
                }
                Existing::Other => {
                    return Err(invalid(format!(
                        "{} exists and is not a checkpoint (it starts with {:?}); \
                         choose another path or move that file",
                        self.path.display(),
                        file_start(&self.path)
                    )))
                }
            }
            // Saving would fail only after the first iterations.
            if meta.permissions().readonly() {
                return Err(invalid(format!(
                    "{} is read-only, so no checkpoint could be saved there",
                    self.path.display()
                )));
            }
        }
        Ok(())
    }
}

/// What a non-empty file at a checkpoint path is.
enum Existing {
    /// A checkpoint (of this layout, whole; or of another version).
    Checkpoint,
    /// A file that declares the checkpoint format but does not parse as a
    /// checkpoint (truncated, or a hand edit broke its JSON): the parser's
    /// error, which names the line and column.
    Damaged(serde_json::Error),
    /// Anything else: the user's data, a model file, unreadable.
    Other,
}

/// Tells what the file at `path` is (see [`Existing`]). A JSON object whose
/// `format` is a checkpoint's (in any field order) is a checkpoint if it
/// parses whole; one that does not parse is damaged if its beginning says
/// `"format": "metriplectic-checkpoint"`.
fn examine(path: &Path) -> Existing {
    use std::io::{BufReader, Read};
    #[derive(Deserialize)]
    struct Tagged {
        format: String,
        #[serde(default)]
        version: Option<u32>,
    }
    let open = || std::fs::File::open(path).map(BufReader::new);
    let mut start = Vec::new();
    let declared = open()
        .and_then(|file| file.take(4096).read_to_end(&mut start))
        .is_ok()
        && declares_format(&String::from_utf8_lossy(&start));
    let Ok(file) = open() else {
        return Existing::Other;
    };
    match serde_json::from_reader::<_, Tagged>(file) {
        Ok(tagged) if tagged.format == FORMAT && tagged.version == Some(VERSION) => {
            // A hand edit may also break a value's type: read it as `load` does.
            match open().map(serde_json::from_reader::<_, CheckpointFile>) {
                Ok(Err(error)) => Existing::Damaged(error),
                Ok(Ok(_)) | Err(_) => Existing::Checkpoint,
            }
        }
        // Another version's checkpoint: the run's own kind of file.
        Ok(tagged) if tagged.format == FORMAT => Existing::Checkpoint,
        Ok(_) => Existing::Other,
        Err(error) if declared => Existing::Damaged(error),
        Err(_) => Existing::Other,
    }
}

/// Whether `text` (a file's beginning) holds `"format": "metriplectic-checkpoint"`,
/// as every checkpoint begins.
fn declares_format(text: &str) -> bool {
    const KEY: &str = "\"format\"";
    let mut rest = text;
    while let Some(at) = rest.find(KEY) {
        rest = &rest[at + KEY.len()..];
        let value = rest.trim_start().strip_prefix(':').map(str::trim_start);
        if value.is_some_and(|v| v.starts_with(&format!("\"{FORMAT}\""))) {
            return true;
        }
    }
    false
}

/// The first 40 bytes of the file at `path`, for an error message.
fn file_start(path: &Path) -> String {
    use std::io::Read;
    let mut start = Vec::new();
    match std::fs::File::open(path).and_then(|file| file.take(40).read_to_end(&mut start)) {
        Ok(_) => String::from_utf8_lossy(&start).into_owned(),
        Err(e) => format!("<unreadable: {e}>"),
    }
}

/// Format tag written into every checkpoint.
const FORMAT: &str = "metriplectic-checkpoint";
/// Version of the checkpoint layout.
/// Version 3: one `search` options block, stopping rules and the best model.
const VERSION: u32 = 3;

/// What a checkpoint was taken of: a resumed run must match it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
struct Fingerprint {
    system: String,
    dim: usize,
    entropy_coefficients: usize,
    metric_coefficients: usize,
    samples: usize,
    /// FNV-1a over the bits of every state and derivative, as hex.
    data_hash: String,
}

impl Fingerprint {
    fn of<S: MetriplecticSystem>(data: &impl IdentificationData) -> Self {
        Self {
            system: S::NAME.to_owned(),
            dim: S::DIM,
            entropy_coefficients: S::entropy_coefficient_count(),
            metric_coefficients: S::metric_coefficient_count(),
            samples: data.equation_count(),
            data_hash: format!("{:016x}", data_hash(data)),
        }
    }
}

/// FNV-1a (64 bit) over the dimension and the bit patterns of the data: any
/// change of any value (even one ulp) changes it with high probability.
fn data_hash(data: &impl IdentificationData) -> u64 {
    fnv1a(data.equations().words().flat_map(u64::to_le_bytes))
}

/// FNV-1a (64 bit) of `bytes`.
fn fnv1a(bytes: impl IntoIterator<Item = u8>) -> u64 {
    const PRIME: u64 = 0x0000_0100_0000_01b3;
    bytes.into_iter().fold(0xcbf2_9ce4_8422_2325, |hash, byte| {
        (hash ^ u64::from(byte)).wrapping_mul(PRIME)
    })
}

/// The on-disk form of a checkpoint.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct CheckpointFile {
    format: String,
    version: u32,
    fingerprint: Fingerprint,
    /// The run's configuration, [`comparable`] form.
    config: IdentifyConfig,
    entropy: Vec<f64>,
    metric: Vec<f64>,
    history: History,
    /// Word position of the ChaCha8 minibatch generator (seeded from
    /// `config.seed`), as a decimal string: it is a u128.
    rng_word_position: String,
    radius: f64,
    failed_in_a_row: usize,
    ever_accepted: bool,
    stopped: Option<StopReason>,
    /// The best-scoring model so far (entropy, metric) and its score.
    best: Option<(Vec<f64>, Vec<f64>, Cost)>,
    since_improvement: usize,
    /// The Gram certificates of the current and the best model, so that a
    /// resumed run returns the proof an uninterrupted one would (absent
    /// from checkpoints of earlier versions: read as none).
    #[serde(default)]
    certificate: Option<GramCertificate>,
    #[serde(default)]
    best_certificate: Option<GramCertificate>,
    /// H and Π of the system at a few states: a resumed run must have the
    /// same known parts (absent from earlier checkpoints: not checked).
    #[serde(default)]
    known_parts: Option<KnownParts>,
    /// FNV-1a (64 bit, hex) of the file's JSON with this field `null`: a
    /// checkpoint is resumed only as the run left it (absent from earlier
    /// checkpoints: not checked).
    #[serde(default)]
    digest: Option<String>,
}

impl CheckpointFile {
    /// The digest of this file's content, `digest` itself left out.
    fn content_digest(&self) -> Result<String> {
        let unsigned = CheckpointFile {
            digest: None,
            ..self.clone()
        };
        let json = serde_json::to_string(&unsigned).map_err(|source| Error::Json {
            context: Some("checkpoint".to_owned()),
            source,
        })?;
        Ok(format!("{:016x}", fnv1a(json.bytes())))
    }
}

/// The configuration as the fingerprint compares it: the iteration cap may
/// be raised on resume and the checkpoint settings may change.
fn comparable(config: &IdentifyConfig) -> IdentifyConfig {
    IdentifyConfig {
        max_iterations: 0,
        checkpoint: None,
        ..config.clone()
    }
}

/// The largest checkpoint accepted for a run of `max_iterations`: 64 MiB
/// plus 16 KiB per iteration (a history record takes about 2 KiB).
fn size_limit(max_iterations: usize) -> u64 {
    // Saturating: `max_iterations` may be usize::MAX for "no cap".
    (16_u64 << 10)
        .saturating_mul(max_iterations as u64)
        .saturating_add(64 << 20)
}

/// Saves `state` of a run of system `S` on `data` with `config` to `path`.
pub(crate) fn save<S: MetriplecticSystem>(
    path: &Path,
    data: &impl IdentificationData,
    config: &IdentifyConfig,
    state: &RunState<S>,
) -> Result<()> {
    let file = CheckpointFile {
        format: FORMAT.to_owned(),
        version: VERSION,
        fingerprint: Fingerprint::of::<S>(data),
        config: comparable(config),
        entropy: state.model.entropy_coefficients().to_vec(),
        metric: state.model.metric_coefficients().to_vec(),
        history: state.history.clone(),
        rng_word_position: state.rng.get_word_pos().to_string(),
        radius: state.radius,
        failed_in_a_row: state.failed_in_a_row,
        ever_accepted: state.ever_accepted,
        stopped: state.stopped,
        best: state.best.as_ref().map(|(model, cost)| {
            (
                model.entropy_coefficients().to_vec(),
                model.metric_coefficients().to_vec(),
                *cost,
            )
        }),
        since_improvement: state.since_improvement,
        certificate: state.model.certificate().cloned(),
        best_certificate: state
            .best
            .as_ref()
            .and_then(|(model, _)| model.certificate().cloned()),
        known_parts: KnownParts::of::<S>(),
        digest: None,
    };
    let file = CheckpointFile {
        digest: Some(file.content_digest()?),
        ..file
    };
    let json = serde_json::to_string(&file).map_err(|source| Error::Json {
        context: Some(path.display().to_string()),
        source,
    })?;
    write_file(path, json.as_bytes(), WriteMode::Overwrite)
}

/// Loads the checkpoint at `path` and checks that it belongs to a run of
/// system `S` on `data` with `config`.
pub(crate) fn load<S: MetriplecticSystem>(
    path: &Path,
    data: &impl IdentificationData,
    config: &IdentifyConfig,
) -> Result<RunState<S>> {
    let mismatch = |reason: String| Error::CheckpointMismatch {
        path: path.to_owned(),
        reason,
    };
    let limit = size_limit(config.max_iterations);
    let text = read_capped(path, limit, "a checkpoint")?;
    let file: CheckpointFile = serde_json::from_str(&text).map_err(|source| Error::Json {
        context: Some(format!(
            "checkpoint {} (damaged or edited: it cannot be resumed as it is)",
            path.display()
        )),
        source,
    })?;
    if file.format != FORMAT || file.version != VERSION {
        return Err(mismatch(format!(
            "format `{}` version {} is not `{FORMAT}` version {VERSION}",
            file.format, file.version
        )));
    }
    let expected = Fingerprint::of::<S>(data);
    if file.fingerprint.system != expected.system
        || file.fingerprint.dim != expected.dim
        || file.fingerprint.entropy_coefficients != expected.entropy_coefficients
        || file.fingerprint.metric_coefficients != expected.metric_coefficients
    {
        return Err(mismatch(format!(
            "it is of system `{}` (n = {}, {} entropy and {} metric coefficients), not `{}` (n = {}, {} and {})",
            file.fingerprint.system,
            file.fingerprint.dim,
            file.fingerprint.entropy_coefficients,
            file.fingerprint.metric_coefficients,
            expected.system,
            expected.dim,
            expected.entropy_coefficients,
            expected.metric_coefficients
        )));
    }
    if let Some(difference) = file
        .known_parts
        .as_ref()
        .and_then(KnownParts::difference::<S>)
    {
        return Err(mismatch(format!(
            "it is of system `{}` with {difference}",
            file.fingerprint.system
        )));
    }
    if file.fingerprint != expected {
        return Err(mismatch(format!(
            "it was taken on other data ({} samples, hash {}; these are {} samples, hash {})",
            file.fingerprint.samples,
            file.fingerprint.data_hash,
            expected.samples,
            expected.data_hash
        )));
    }
    let wanted = comparable(config);
    if file.config != wanted {
        return Err(mismatch(format!(
            "the configuration differs in {}",
            differing_fields(&file.config, &wanted).join(", ")
        )));
    }
    // After the checks that name a changed system, data or configuration:
    // an edited stop reason, best model or generator position resumed as
    // given (a probe's "Converged" stopped a run at held-out error 8e-3).
    if let Some(digest) = &file.digest {
        let content = file.content_digest()?;
        if *digest != content {
            return Err(mismatch(format!(
                "its content does not match the digest it was saved with ({digest}; the content \
                 gives {content}): it was edited or damaged after the run wrote it, and a resumed \
                 run would not continue the one that was interrupted; start a new run, or restore \
                 the file"
            )));
        }
    }
    let numbered = file
        .history
        .iterations
        .iter()
        .enumerate()
        .all(|(i, r)| r.iteration == i + 1);
    if !numbered {
        return Err(mismatch(
            "its history is not numbered 1, 2, … (edited or corrupt)".to_owned(),
        ));
    }
    let word_position: u128 = file.rng_word_position.parse().map_err(|e| {
        mismatch(format!(
            "generator position `{}` is not a number: {e}",
            file.rng_word_position
        ))
    })?;
    if !(file.radius.is_finite() && file.radius >= 0.0) {
        return Err(mismatch(format!(
            "trust radius {} is not finite and non-negative",
            file.radius
        )));
    }
    // The joint step keeps its radius in [min_radius, max_radius]; an
    // edited radius outside it would fail the first step far from here.
    if let IterationScheme::AlternatingThenJoint(trust) = &config.scheme {
        if !(trust.min_radius..=trust.max_radius).contains(&file.radius) {
            return Err(mismatch(format!(
                "trust radius {:e} is outside the configuration's [{:e}, {:e}]",
                file.radius, trust.min_radius, trust.max_radius
            )));
        }
    }
    // The metric is certified anew either way; a kept certificate must fit
    // the system's blocks.
    // Errors name the file and the model ("metric coefficients in the best
    // model of checkpoint PATH: …").
    let certified =
        |which: &str, entropy: Vec<f64>, metric: Vec<f64>, certificate: Option<GramCertificate>| {
            Model::<S>::new(entropy, metric)
                .and_then(|model| match certificate {
                    Some(certificate) => model.with_certificate(certificate),
                    None => Ok(model),
                })
                .map_err(|e| {
                    e.located(&format!(
                        "the {which} model of checkpoint {}",
                        path.display()
                    ))
                })
        };
    let model = certified("current", file.entropy, file.metric, file.certificate)?;
    let best = match file.best {
        Some((entropy, metric, cost)) => Some((
            certified("best", entropy, metric, file.best_certificate)?,
            cost,
        )),
        None => None,
    };
    let mut rng = ChaCha8Rng::seed_from_u64(config.seed);
    rng.set_word_pos(word_position);
    Ok(RunState {
        model,
        history: file.history,
        rng,
        failed_in_a_row: file.failed_in_a_row,
        ever_accepted: file.ever_accepted,
        radius: file.radius,
        stopped: file.stopped,
        best,
        since_improvement: file.since_improvement,
    })
}

/// Names of the top-level configuration fields that differ.
fn differing_fields(a: &IdentifyConfig, b: &IdentifyConfig) -> Vec<String> {
    let (Ok(serde_json::Value::Object(a)), Ok(serde_json::Value::Object(b))) =
        (serde_json::to_value(a), serde_json::to_value(b))
    else {
        return vec!["(unknown fields)".to_owned()];
    };
    let mut fields: Vec<String> = a
        .iter()
        .filter(|(key, value)| b.get(*key) != Some(*value))
        .map(|(key, value)| {
            let now = b.get(key).map_or("(absent)".to_owned(), |v| v.to_string());
            format!("`{key}` (checkpoint {value}, now {now})")
        })
        .collect();
    if fields.is_empty() {
        fields.push("(values that print alike)".to_owned());
    }
    fields
}

#[cfg(test)]
mod tests {
    use super::declares_format;

    #[test]
    fn a_damaged_checkpoint_is_told_by_its_declared_format() {
        assert!(declares_format(
            r#"{"format":"metriplectic-checkpoint","version":3,"fing"#
        ));
        assert!(declares_format(
            "{\n  \"version\": 3,\n  \"format\" :\n \"metriplectic-checkpoint\",\n"
        ));
        assert!(!declares_format(
            r#"{"format":"metriplectic-model","version":1}"#
        ));
        assert!(!declares_format(r#"{"format":"#));
        assert!(!declares_format("trajectory,t,q,p\n0,0,1,2\n"));
        assert!(!declares_format(r#"{"formats":"metriplectic-checkpoint"}"#));
    }
}
