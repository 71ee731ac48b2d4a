//! Saving and loading a [`Model`] as JSON.
//!
//! The file records which system and bases the coefficients belong to (name,
//! state names, degrees, exponent tables) and the system's H and Π at a few
//! states, so loading into another system — or into the same name with
//! different bases, or with an edited H or Π — fails with
//! [`Error::WrongSystem`] instead of silently misreading the coefficients.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::known_parts::KnownParts;
use super::{GramCertificate, Model};
use crate::error::{Error, Result};
use crate::io::{read_capped, write_file, WriteMode};
use crate::system::{CertificateMode, MetriplecticSystem, Region};

/// Format tag written into every model file.
const FORMAT: &str = "metriplectic-model";
/// Version of the file layout.
const VERSION: u32 = 1;

/// The on-disk form of a model. Unknown fields are refused: a misspelt
/// `certficate` would otherwise load the model without its certificate
/// (every field ever written is still here, so older files load).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ModelFile {
    format: String,
    version: u32,
    system: String,
    state_names: Vec<String>,
    entropy_degree: u32,
    metric_degree: u32,
    entropy_exponents: Vec<Vec<u32>>,
    metric_exponents: Vec<Vec<u32>>,
    /// The region of the system's metric certificate, if it declares one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    region: Option<RegionFile>,
    /// Which bounds the certificate proves where.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    certificate_mode: Option<CertificateMode>,
    /// Where dE/dt ≥ 0 is certified, in words, for readers of the file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    free_energy_certified: Option<String>,
    /// Generalized or classical (GENERIC); files written before the
    /// classical form existed are generalized.
    #[serde(default)]
    formalism: Formalism,
    /// H and Π at a few states, so that a model is not loaded into a system
    /// whose known parts changed under the same name and bases; files
    /// written before it was recorded load without the check.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    known_parts: Option<KnownParts>,
    entropy: Vec<f64>,
    metric: Vec<f64>,
    /// The Gram matrices proving the metric's bounds, when known.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    certificate: Option<GramCertificate>,
}

/// Which form of the equations a model file's coefficients satisfy.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
enum Formalism {
    /// ẋ = (Π + K)(∇H + ∇S), E = H + S non-decreasing.
    #[default]
    Generalized,
    /// Π∇S ≡ 0 and K∇H ≡ 0: H conserved, S non-decreasing.
    Classical,
}

impl Formalism {
    fn of<S: MetriplecticSystem>() -> Self {
        if S::CLASSICAL.is_some() {
            Self::Classical
        } else {
            Self::Generalized
        }
    }
}

/// A [`Region`] as stored in a model file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
enum RegionFile {
    Ball { center: Vec<f64>, radius: f64 },
    Box { lower: Vec<f64>, upper: Vec<f64> },
}

impl From<Region> for RegionFile {
    fn from(region: Region) -> Self {
        match region {
            Region::Ball { center, radius } => Self::Ball {
                center: center.to_vec(),
                radius,
            },
            Region::Box { lower, upper } => Self::Box {
                lower: lower.to_vec(),
                upper: upper.to_vec(),
            },
        }
    }
}

/// Where a system's certificate proves dE/dt ≥ 0, in words.
fn free_energy_certified<S: MetriplecticSystem>() -> Option<String> {
    S::REGION_CERTIFICATE.map(|certificate| {
        match certificate.mode {
            CertificateMode::GlobalLowerBound => "for every state (K(x) ⪰ 0 everywhere)",
            CertificateMode::OnRegion => {
                "only for states in the region (K(x) ⪰ 0 is certified on the region only)"
            }
        }
        .to_owned()
    })
}

impl ModelFile {
    fn describe(&self) -> String {
        describe(
            &self.system,
            &self.state_names,
            self.entropy_degree,
            self.metric_degree,
        )
    }

    fn header_of<S: MetriplecticSystem>() -> Self {
        Self {
            format: FORMAT.to_owned(),
            version: VERSION,
            system: S::NAME.to_owned(),
            state_names: S::STATE_NAMES.iter().map(|s| (*s).to_owned()).collect(),
            entropy_degree: S::ENTROPY_DEGREE,
            metric_degree: S::METRIC_DEGREE,
            entropy_exponents: to_owned_table(S::ENTROPY_EXPONENTS),
            metric_exponents: to_owned_table(S::METRIC_EXPONENTS),
            region: S::REGION_CERTIFICATE.map(|c| c.region.into()),
            certificate_mode: S::REGION_CERTIFICATE.map(|c| c.mode),
            free_energy_certified: free_energy_certified::<S>(),
            formalism: Formalism::of::<S>(),
            known_parts: None,
            entropy: Vec::new(),
            metric: Vec::new(),
            certificate: None,
        }
    }
}

/// The largest model file accepted for system `S`: 1 MiB plus 256 bytes
/// per number in the file (pretty-printed JSON needs about 30), so hand
/// edits and reformatting fit while a corrupt or hostile file cannot make
/// the reader allocate without bound.
fn model_file_limit<S: MetriplecticSystem>() -> u64 {
    // The certificate's Gram matrices: the full global tables are the
    // largest a system without a region can have.
    let layout = super::Layout::of::<S>(S::SOS_FULL);
    let gram: usize = layout
        .lower
        .iter()
        .chain(&layout.upper)
        .map(|block| block.size(S::DIM).pow(2))
        .sum();
    let numbers = S::entropy_coefficient_count()
        + S::metric_coefficient_count()
        + gram
        + (S::ENTROPY_EXPONENTS.len() + S::METRIC_EXPONENTS.len() + 3) * S::DIM;
    (1 << 20) + 256 * numbers as u64
}

fn to_owned_table(table: &[&[u32]]) -> Vec<Vec<u32>> {
    table.iter().map(|e| e.to_vec()).collect()
}

fn describe<N: AsRef<str>>(name: &str, states: &[N], entropy: u32, metric: u32) -> String {
    let states: Vec<&str> = states.iter().map(AsRef::as_ref).collect();
    format!(
        "system `{name}` (state ({}), entropy degree {entropy}, metric degree {metric})",
        states.join(", ")
    )
}

impl<S: MetriplecticSystem> Model<S> {
    /// The model as pretty-printed JSON, with its system and bases.
    pub fn to_json(&self) -> Result<String> {
        let file = ModelFile {
            entropy: self.entropy_coefficients().to_vec(),
            metric: self.metric_coefficients().to_vec(),
            certificate: self.certificate().cloned(),
            known_parts: KnownParts::of::<S>(),
            ..ModelFile::header_of::<S>()
        };
        serde_json::to_string_pretty(&file).map_err(|source| Error::Json {
            context: Some(format!("model of system `{}`", S::NAME)),
            source,
        })
    }

    /// Parses a model written by [`Model::to_json`].
    ///
    /// Fails with [`Error::WrongSystem`] if the JSON belongs to another
    /// system or to other bases, with [`Error::Json`] naming the field if it
    /// holds a field no model file has (a misspelt `certficate` would
    /// otherwise load the model without its certificate), and with the
    /// usual length/finiteness errors if the coefficients are malformed.
    pub fn from_json(json: &str) -> Result<Self> {
        let limit = model_file_limit::<S>();
        if json.len() as u64 > limit {
            return Err(Error::InvalidArgument {
                what: "model file".to_owned(),
                reason: format!(
                    "{} bytes is more than the {limit} a model of system `{}` can take",
                    json.len(),
                    S::NAME
                ),
            });
        }
        // Editors on some platforms prepend a byte-order mark; JSON has none.
        let json = json.strip_prefix('\u{feff}').unwrap_or(json);
        let file: ModelFile = serde_json::from_str(json).map_err(|source| Error::Json {
            context: Some("model file".to_owned()),
            source,
        })?;
        if file.format != FORMAT || file.version != VERSION {
            return Err(Error::InvalidArgument {
                what: "model file".to_owned(),
                reason: format!(
                    "format `{}` version {} is not `{FORMAT}` version {VERSION}",
                    file.format, file.version
                ),
            });
        }
        let expected = ModelFile::header_of::<S>();
        let found_header = ModelFile {
            entropy: Vec::new(),
            metric: Vec::new(),
            certificate: None,
            known_parts: None,
            ..file.clone()
        };
        if found_header != expected {
            let mut found = file.describe();
            if file.system == expected.system
                && file.state_names == expected.state_names
                && file.entropy_degree == expected.entropy_degree
                && file.metric_degree == expected.metric_degree
            {
                found.push_str(if file.formalism != expected.formalism {
                    match file.formalism {
                        Formalism::Classical => " in the classical form",
                        Formalism::Generalized => " in the generalized form",
                    }
                } else if file.region != expected.region
                    || file.certificate_mode != expected.certificate_mode
                {
                    " with a different certificate region or mode"
                } else if file.free_energy_certified != expected.free_energy_certified {
                    " whose `free_energy_certified` text was edited (it follows from the region and mode)"
                } else {
                    " with different monomial tables"
                });
            }
            return Err(Error::WrongSystem {
                expected: expected.describe(),
                found,
            });
        }
        if let Some(difference) = file
            .known_parts
            .as_ref()
            .and_then(KnownParts::difference::<S>)
        {
            return Err(Error::WrongSystem {
                expected: expected.describe(),
                found: format!("{} with {difference}", file.describe()),
            });
        }
        let model = Self::new(file.entropy, file.metric)?;
        match file.certificate {
            Some(certificate) => model.with_certificate(certificate),
            None => Ok(model),
        }
    }

    /// Writes the model to `path` as JSON. With [`WriteMode::CreateNew`]
    /// an existing file is refused ([`Error::FileExists`]); with
    /// [`WriteMode::Overwrite`] it is replaced. Either way the write is
    /// atomic: if it fails (a full disk, a crash) the previous file is left
    /// as it was and no partial file appears.
    pub fn save(&self, path: impl AsRef<Path>, mode: WriteMode) -> Result<()> {
        let mut json = self.to_json()?;
        json.push('\n');
        write_file(path.as_ref(), json.as_bytes(), mode)
    }

    /// Reads a model written by [`Model::save`].
    ///
    /// Files larger than a model of `S` can plausibly be (1 MiB plus 256
    /// bytes per number the file holds) are refused with
    /// [`Error::FileTooLarge`] before they are read into memory. Every error
    /// names the file: the variants are those of [`Model::from_json`], with
    /// the path in the quantity they name (e.g. "metric coefficients in
    /// model file PATH: K(x) is not positive semidefinite …", "invalid JSON
    /// in PATH: unknown field `certficate` …").
    pub fn load(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let json = read_capped(path, model_file_limit::<S>(), "a model file")?;
        let place = format!("model file {}", path.display());
        Self::from_json(&json).map_err(|e| match e {
            Error::Json { source, .. } => Error::Json {
                context: Some(path.display().to_string()),
                source,
            },
            // `from_json` calls the whole file "model file".
            Error::InvalidArgument { what, reason } if what == "model file" => {
                Error::InvalidArgument {
                    what: place.clone(),
                    reason,
                }
            }
            other => other.located(&place),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::Model;
    use crate::error::Error;
    use crate::test_system::Quadratic2d;
    use crate::WriteMode;

    #[test]
    fn json_round_trip_is_exact() {
        let model = Model::<Quadratic2d>::reference().unwrap();
        let json = model.to_json().unwrap();
        assert!(json.contains("\"Quadratic2d\""));
        assert_eq!(Model::<Quadratic2d>::from_json(&json).unwrap(), model);
    }

    #[test]
    fn changed_bases_are_rejected_by_name() {
        let json = Model::<Quadratic2d>::reference()
            .unwrap()
            .to_json()
            .unwrap();
        let edited = json.replacen("\"metric_degree\": 2", "\"metric_degree\": 4", 1);
        assert_ne!(edited, json);
        let err = Model::<Quadratic2d>::from_json(&edited).unwrap_err();
        assert!(matches!(err, Error::WrongSystem { .. }), "{err}");
        let message = err.to_string();
        assert!(message.contains("metric degree 4") && message.contains("metric degree 2"));
    }

    #[test]
    fn save_refuses_to_overwrite_unless_asked() {
        let dir =
            std::env::temp_dir().join(format!("metriplectic-model-io-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("model.json");
        let _ = std::fs::remove_file(&path);
        let model = Model::<Quadratic2d>::reference().unwrap();
        model.save(&path, WriteMode::CreateNew).unwrap();
        assert!(matches!(
            model.save(&path, WriteMode::CreateNew),
            Err(Error::FileExists { .. })
        ));
        let other = Model::<Quadratic2d>::with_identity_metric(vec![1.0; 5]).unwrap();
        other.save(&path, WriteMode::Overwrite).unwrap();
        assert_eq!(Model::<Quadratic2d>::load(&path).unwrap(), other);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
