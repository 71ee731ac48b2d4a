//! Model files: saving never loses what was there (atomic writes under a
//! full disk, no silent overwrite), and loading refuses what would break the
//! model (wrong system, indefinite metric, absurd coefficients) while
//! accepting what editors add (a byte-order mark).

use std::path::PathBuf;

use metriplectic_runtime::prelude::*;
use metriplectic_runtime::WriteMode;

use crate::common::RigidBody;

fn scratch(name: &str) -> PathBuf {
    crate::common::scratch_dir("model_files", name)
}

/// A model different from the reference, so that its file differs too.
fn other_model() -> Model<RigidBody> {
    let reference = Model::<RigidBody>::reference().unwrap();
    let entropy = reference
        .entropy_coefficients()
        .iter()
        .map(|c| c + 0.125)
        .collect();
    Model::new(entropy, reference.metric_coefficients().to_vec()).unwrap()
}

/// Child mode of the test below: with the file size limited (a full disk),
/// saving must fail with an error.
#[test]
#[ignore = "run by saving_onto_a_full_disk_keeps_the_previous_file"]
fn save_child() {
    if let Ok(path) = std::env::var("METRIPLECTIC_SAVE_PATH") {
        let err = other_model()
            .save(&path, WriteMode::Overwrite)
            .expect_err("the file size limit makes the write fail");
        println!("child: {err}");
    }
}

#[test]
fn saving_onto_a_full_disk_keeps_the_previous_file() {
    let dir = scratch("full-disk");
    let path = dir.join("model.json");
    let previous = Model::<RigidBody>::reference().unwrap();
    previous.save(&path, WriteMode::CreateNew).unwrap();
    assert!(std::fs::metadata(&path).unwrap().len() > 2048);
    // `ulimit -f 2` caps files at 1–2 KiB (writes beyond fail with EFBIG,
    // as on a full disk); SIGXFSZ is ignored so the write returns an error.
    // The child's output goes to pipes: the limit applies to every file the
    // child writes, and an inherited stdout redirected to a log file (as in
    // CI) is already past it.
    let exe = std::env::current_exe().unwrap();
    let output = std::process::Command::new("sh")
        .arg("-c")
        .arg("trap '' XFSZ; ulimit -f 2; exec \"$0\" --exact model_files::save_child --ignored --test-threads=1 --nocapture")
        .arg(&exe)
        .env("METRIPLECTIC_SAVE_PATH", &path)
        .stdin(std::process::Stdio::null())
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "the child's save did not fail as it should:\n{}\n{}",
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(
        String::from_utf8_lossy(&output.stdout).contains("child: "),
        "the child did not run the save"
    );
    // The previous model is intact and nothing else is left beside it.
    assert_eq!(Model::<RigidBody>::load(&path).unwrap(), previous);
    let names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, vec![std::ffi::OsString::from("model.json")]);
}

#[test]
fn saving_never_overwrites_unless_asked_and_replaces_atomically() {
    let dir = scratch("modes");
    let path = dir.join("model.json");
    let first = Model::<RigidBody>::reference().unwrap();
    first.save(&path, WriteMode::CreateNew).unwrap();
    let err = other_model().save(&path, WriteMode::CreateNew).unwrap_err();
    assert!(matches!(err, Error::FileExists { .. }), "{err}");
    assert_eq!(Model::<RigidBody>::load(&path).unwrap(), first);
    #[cfg(unix)]
    let inode = {
        use std::os::unix::fs::MetadataExt;
        std::fs::metadata(&path).unwrap().ino()
    };
    other_model().save(&path, WriteMode::Overwrite).unwrap();
    assert_eq!(Model::<RigidBody>::load(&path).unwrap(), other_model());
    // Replaced by a rename of a complete file, not rewritten in place.
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        assert_ne!(std::fs::metadata(&path).unwrap().ino(), inode);
    }
}

#[test]
fn saving_onto_a_directory_says_so() {
    let dir = scratch("directory");
    let err = other_model().save(&dir, WriteMode::Overwrite).unwrap_err();
    let message = err.to_string();
    assert!(message.contains("is a directory"), "{message}");
    assert!(!matches!(err, Error::FileExists { .. }));
}

#[test]
fn a_byte_order_mark_is_accepted() {
    let dir = scratch("bom");
    let path = dir.join("model.json");
    let json = Model::<RigidBody>::reference().unwrap().to_json().unwrap();
    std::fs::write(&path, format!("\u{feff}{json}")).unwrap();
    assert_eq!(
        Model::<RigidBody>::load(&path).unwrap(),
        Model::<RigidBody>::reference().unwrap()
    );
}

#[test]
fn absurd_coefficients_are_refused_by_name() {
    let json = Model::<RigidBody>::reference().unwrap().to_json().unwrap();
    let mut value: serde_json::Value = serde_json::from_str(&json).unwrap();
    value["entropy"][3] = serde_json::json!(1e300);
    let err = Model::<RigidBody>::from_json(&value.to_string()).unwrap_err();
    let message = err.to_string();
    assert!(
        message.contains("entropy")
            && message.contains("coefficient 3")
            && message.contains("1e300"),
        "{message}"
    );
}

mod first {
    metriplectic_runtime::metriplectic! {
        /// An oscillator as first declared.
        pub struct Osc;
        state (x, v);
        poisson = [[0, -1], [1, 0]];
        hamiltonian = 0.5 * v^2 + 0.5 * x^2;
        entropy degree 2;
        metric degree 0;
    }
}

mod stiffer {
    metriplectic_runtime::metriplectic! {
        /// The same name, state and bases with a stiffer spring.
        pub struct Osc;
        state (x, v);
        poisson = [[0, -1], [1, 0]];
        hamiltonian = 0.5 * v^2 + 5 * x^2;
        entropy degree 2;
        metric degree 0;
    }
}

mod reversed {
    metriplectic_runtime::metriplectic! {
        /// The same with the Poisson tensor's sign flipped.
        pub struct Osc;
        state (x, v);
        poisson = [[0, 1], [-1, 0]];
        hamiltonian = 0.5 * v^2 + 0.5 * x^2;
        entropy degree 2;
        metric degree 0;
    }
}

/// A model means nothing for another H or Π, but a file named its system
/// only by name, state and bases, which an edited constant leaves as they
/// were: a probe's model loaded into an `Osc` with another H and Π, and
/// its free energy and field changed without a word.
#[test]
fn a_model_does_not_load_into_a_system_whose_hamiltonian_or_poisson_changed() {
    let entropy = vec![-0.5; first::Osc::entropy_coefficient_count()];
    let model = Model::<first::Osc>::new(entropy, vec![1.0, 0.0, 1.0]).unwrap();
    let json = model.to_json().unwrap();
    assert_eq!(Model::<first::Osc>::from_json(&json).unwrap(), model);

    let error = Model::<stiffer::Osc>::from_json(&json).unwrap_err();
    println!("{error}");
    assert!(matches!(error, Error::WrongSystem { .. }), "{error}");
    assert!(
        error.to_string().contains("with another Hamiltonian: H = "),
        "{error}"
    );
    let error = Model::<reversed::Osc>::from_json(&json).unwrap_err();
    assert!(
        error
            .to_string()
            .contains("with another Poisson tensor: Π[0][1] = -1e0 in the file, 1e0 in the system"),
        "{error}"
    );

    // A file written before H and Π were recorded still loads.
    let mut value: serde_json::Value = serde_json::from_str(&json).unwrap();
    value.as_object_mut().unwrap().remove("known_parts");
    let older = serde_json::to_string(&value).unwrap();
    assert_eq!(
        Model::<stiffer::Osc>::from_json(&older)
            .unwrap()
            .entropy_coefficients(),
        model.entropy_coefficients()
    );
}

/// A misspelt field was ignored: a model file whose `certificate` was
/// written `certficate` loaded without its certificate, and any other
/// typo dropped what it held without a word.
#[test]
fn unknown_fields_are_refused_by_name() {
    let dir = scratch("unknown-fields");
    let json = Model::<RigidBody>::reference().unwrap().to_json().unwrap();
    let value: serde_json::Value = serde_json::from_str(&json).unwrap();
    for (field, replacing) in [("certficate", None), ("metrik", Some("metric"))] {
        let mut edited = value.clone();
        let object = edited.as_object_mut().unwrap();
        let content = match replacing {
            Some(old) => object.remove(old).unwrap(),
            None => serde_json::json!({"lower": []}),
        };
        object.insert(field.to_owned(), content);
        let text = serde_json::to_string_pretty(&edited).unwrap();
        let err = Model::<RigidBody>::from_json(&text).unwrap_err();
        assert!(matches!(err, Error::Json { .. }), "{err}");
        assert!(
            err.to_string()
                .contains(&format!("unknown field `{field}`")),
            "{err}"
        );
        let path = dir.join(format!("{field}.json"));
        std::fs::write(&path, &text).unwrap();
        let err = Model::<RigidBody>::load(&path).unwrap_err();
        let message = err.to_string();
        assert!(
            message.contains(path.to_str().unwrap())
                && message.contains(&format!("unknown field `{field}`")),
            "{message}"
        );
    }
}

/// Refusing unknown fields must not refuse the files earlier versions
/// wrote: the first layout had only the system, its bases and the
/// coefficients (no region, formalism, H and Π, certificate).
#[test]
fn files_written_by_earlier_versions_still_load() {
    let model = Model::<RigidBody>::reference().unwrap();
    let json = model.to_json().unwrap();
    let value: serde_json::Value = serde_json::from_str(&json).unwrap();
    let first_layout = [
        "format",
        "version",
        "system",
        "state_names",
        "entropy_degree",
        "metric_degree",
        "entropy_exponents",
        "metric_exponents",
        "entropy",
        "metric",
    ];
    let object = value.as_object().unwrap();
    let mut older = serde_json::Map::new();
    for key in first_layout {
        older.insert(key.to_owned(), object[key].clone());
    }
    let loaded =
        Model::<RigidBody>::from_json(&serde_json::Value::Object(older).to_string()).unwrap();
    assert_eq!(loaded.entropy_coefficients(), model.entropy_coefficients());
    assert_eq!(loaded.metric_coefficients(), model.metric_coefficients());
    // Every field the current version writes is read back.
    assert_eq!(Model::<RigidBody>::from_json(&json).unwrap(), model);
}

/// `Model::load` named the file only in JSON errors: an indefinite metric,
/// another system's file, a wrong count or format said nothing of which
/// file; the variants are those of `from_json`, with the path added.
#[test]
fn every_load_error_names_the_file() {
    let dir = scratch("named");
    let json = Model::<RigidBody>::reference().unwrap().to_json().unwrap();
    let value: serde_json::Value = serde_json::from_str(&json).unwrap();
    let edit = |pointer: &str, new: serde_json::Value| {
        let mut edited = value.clone();
        *edited.pointer_mut(pointer).unwrap() = new;
        if pointer.starts_with("/metric") {
            // The certificate proves the old metric.
            edited.as_object_mut().unwrap().remove("certificate");
        }
        edited.to_string()
    };
    let shorter = {
        let mut entropy = value["entropy"].as_array().unwrap().clone();
        entropy.pop();
        serde_json::Value::Array(entropy)
    };
    let cases: [(&str, String, &str); 4] = [
        (
            "indefinite",
            edit("/metric/0", serde_json::json!(-5.0)),
            "metric coefficients in model file ",
        ),
        (
            "short",
            edit("/entropy", shorter),
            "entropy coefficients in model file ",
        ),
        (
            "version",
            edit("/version", serde_json::json!(7)),
            "invalid model file ",
        ),
        (
            "other_system",
            Model::<crate::common::Linear2d>::reference()
                .unwrap()
                .to_json()
                .unwrap(),
            "according to model file ",
        ),
    ];
    for (name, text, expected) in cases {
        let path = dir.join(format!("{name}.json"));
        std::fs::write(&path, &text).unwrap();
        let err = Model::<RigidBody>::load(&path).unwrap_err();
        let message = err.to_string();
        let named = format!("{expected}{}", path.display());
        assert!(
            message.contains(&named),
            "{name}: `{named}` not in {message}"
        );
        let from_text = Model::<RigidBody>::from_json(&text).unwrap_err();
        assert_eq!(
            std::mem::discriminant(&err),
            std::mem::discriminant(&from_text),
            "{name}: the variant stays: {err} / {from_text}"
        );
    }
}
