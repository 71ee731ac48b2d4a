//! The output directory: checked before the run, written file by file
//! without replacing what the user has unless asked, and the figures.

use std::fs;
use std::path::Path;

use metriplectic_runtime::prelude::*;
use metriplectic_runtime::{
    phase_portrait_2d, trajectories_3d, trajectory_overlay, write_file, Identification, Labels,
    Simulation, WriteMode,
};

use super::validation::{smooth_simulation, trajectory_label, Validation};
use super::{io_error, Context, FromCsvError};

/// The name of the file made (and removed at once) to test that the output
/// directory is writable.
const WRITE_TEST_PREFIX: &str = ".from_csv-write-test-";

/// Refuses an output path that is a file, or a non-empty directory without
/// `overwrite`. Creates nothing: the directory is made once the input has
/// been read, so a bad CSV leaves nothing behind.
pub(super) fn check_output_dir(out: &Path, overwrite: bool) -> Result<(), FromCsvError> {
    match fs::metadata(out) {
        Ok(meta) if !meta.is_dir() => Err(FromCsvError::OutputNotADirectory(out.to_owned())),
        Ok(_) => {
            let entries = fs::read_dir(out).map_err(io_error(out))?;
            // A write test left by a killed run is not the user's file.
            let mut entries = entries.filter(|entry| {
                entry.as_ref().map_or(true, |entry| {
                    !entry
                        .file_name()
                        .to_string_lossy()
                        .starts_with(WRITE_TEST_PREFIX)
                })
            });
            if entries.next().is_some() && !overwrite {
                Err(FromCsvError::OutputNotEmpty(out.to_owned()))
            } else {
                Ok(())
            }
        }
        Err(err) if err.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(err) => Err(io_error(out)(err)),
    }
}

/// Removes the regular files of `out` that a run writes (the fixed
/// outputs and the pipeline's figures, not any other `.png`), so that a run
/// with `--overwrite` does not leave an earlier run's figures beside its
/// own (a probe's rigid-body outputs sat beside a Duffing run's
/// `validation_2..4.png`).
pub(super) fn remove_previous_outputs(out: &Path) -> Result<(), FromCsvError> {
    let Ok(entries) = fs::read_dir(out) else {
        return Ok(());
    };
    for entry in entries {
        let entry = entry.map_err(io_error(out))?;
        let name = entry.file_name();
        let text = name.to_string_lossy();
        let figure = text.ends_with(".png")
            && (text.starts_with("validation_")
                || ["model_trajectories_3d.png", "loss.png", "free_energy.png"]
                    .contains(&text.as_ref()));
        let fixed = FIXED_OUTPUTS.iter().any(|fixed| name == *fixed);
        let path = entry.path();
        if (figure || fixed) && fs::symlink_metadata(&path).is_ok_and(|meta| meta.is_file()) {
            fs::remove_file(&path).map_err(io_error(&path))?;
        }
    }
    Ok(())
}

/// The files every run writes into the output directory (figures that
/// cannot be written are warnings, not failures).
const FIXED_OUTPUTS: [&str; 4] = ["model.json", "equations.txt", "history.csv", "summary.json"];

/// Refuses, before the run, an existing output directory that the run
/// could not write into, or a fixed output name there that is not a
/// regular file (or a link to one) or is read-only: found only when the
/// results were written, such a run was lost. A name that does not exist,
/// or a link to a file that does not exist yet, is fine.
pub(super) fn check_output_files(out: &Path) -> Result<(), FromCsvError> {
    if !out.is_dir() {
        // Made later; `check_output_dir` refused anything else.
        return Ok(());
    }
    let refuse = |path: std::path::PathBuf, reason: String| {
        Err(FromCsvError::OutputNotWritable { path, reason })
    };
    for name in FIXED_OUTPUTS {
        let path = out.join(name);
        match fs::metadata(&path) {
            Ok(meta) if meta.is_dir() => {
                return refuse(
                    path,
                    "it is a directory, where this run writes a file".into(),
                )
            }
            Ok(meta) if !meta.is_file() => return refuse(
                path,
                "it is not a regular file (a FIFO, socket or device), where this run writes a file"
                    .into(),
            ),
            Ok(meta) if meta.permissions().readonly() => {
                return refuse(
                    path,
                    "the file is read-only, so this run could not replace it".into(),
                )
            }
            Ok(_) => {}
            Err(err) if err.kind() == std::io::ErrorKind::NotFound => {}
            Err(err) => return refuse(path, err.to_string()),
        }
    }
    // Whether files can be made there: make one and remove it.
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.subsec_nanos());
    let probe = out.join(format!("{WRITE_TEST_PREFIX}{}-{nanos}", std::process::id()));
    match fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&probe)
    {
        Ok(file) => {
            drop(file);
            // Nothing of the user's: a probe left behind is harmless.
            let _ = fs::remove_file(&probe);
            Ok(())
        }
        // The same name made a moment ago: files can be made there.
        Err(err) if err.kind() == std::io::ErrorKind::AlreadyExists => Ok(()),
        Err(err) => refuse(
            out.to_owned(),
            format!("the output directory is not writable ({err})"),
        ),
    }
}

/// Whether the pipeline may write a file of this name into the output
/// directory: its fixed files, and figures (`.png`).
fn is_output_name(name: &std::ffi::OsStr) -> bool {
    FIXED_OUTPUTS.iter().any(|fixed| name == *fixed)
        || Path::new(name).extension().is_some_and(|e| e == "png")
}

/// Refuses `--overwrite` when the input CSV would be replaced by an output:
/// it is in the output directory under a name the run writes, or such a name
/// there is a symbolic link to it (outputs are written through links).
pub(super) fn check_input_is_not_an_output(
    data: &Path,
    out: &Path,
    overwrite: bool,
) -> Result<(), FromCsvError> {
    let (Ok(data), Ok(out)) = (fs::canonicalize(data), fs::canonicalize(out)) else {
        // No output directory yet, or no input (the reader says so).
        return Ok(());
    };
    if !overwrite {
        // Nothing existing is replaced.
        return Ok(());
    }
    if data.parent() == Some(out.as_path()) && data.file_name().is_some_and(is_output_name) {
        return Err(FromCsvError::InputIsAnOutput(data));
    }
    let entries = fs::read_dir(&out).map_err(io_error(&out))?;
    for entry in entries {
        let entry = entry.map_err(io_error(&out))?;
        let linked = entry.file_type().is_ok_and(|kind| kind.is_symlink());
        if linked
            && is_output_name(&entry.file_name())
            && fs::canonicalize(entry.path()).is_ok_and(|target| target == data)
        {
            return Err(FromCsvError::InputIsAnOutput(entry.path()));
        }
    }
    Ok(())
}

impl Context<'_> {
    /// `validation_<k>.png` (or one per pair of state variables),
    /// `validation_overlay.png` (the same trajectories over time),
    /// `model_trajectories_3d.png` for 3-D systems, `loss.png` and
    /// `free_energy.png`. A figure that cannot be drawn (degenerate data)
    /// is a warning: the model and numbers are still worth having.
    pub(super) fn figures<S: MetriplecticSystem>(
        &self,
        identification: &Identification<S>,
        validation: &[Trajectory],
        checked: &Validation,
        files: &mut Vec<String>,
        warnings: &mut Vec<String>,
    ) -> Result<(), FromCsvError> {
        let out = &self.options.out;
        let mut attempt =
            |name: String, draw: &dyn Fn(&Path) -> metriplectic_runtime::Result<()>| {
                let path = out.join(&name);
                if !self.options.overwrite && path.exists() {
                    return Err(FromCsvError::OutputExists(path));
                }
                match draw(&path) {
                    Ok(()) => files.push(name),
                    Err(err) => warnings.push(format!("{name} not drawn: {err}")),
                }
                Ok(())
            };
        let names = S::STATE_NAMES;
        let pairs: Vec<(usize, usize)> = (0..S::DIM)
            .flat_map(|a| (a + 1..S::DIM).map(move |b| (a, b)))
            .take(3)
            .collect();
        let shown = checked
            .simulations
            .iter()
            .take(self.options.plot_trajectories);
        // Measured against simulated states over time, for the overlay.
        type Series = (Vec<f64>, Vec<Vec<f64>>);
        let series = |trajectory: &Trajectory| -> Series {
            (
                trajectory.times().to_vec(),
                trajectory
                    .states()
                    .chunks_exact(S::DIM)
                    .map(<[f64]>::to_vec)
                    .collect(),
            )
        };
        let mut overlay_data: Vec<Series> = Vec::new();
        let mut overlay_model: Vec<Series> = Vec::new();
        for (number, (index, _)) in shown.enumerate() {
            let measured = &validation[*index];
            let Some(smooth) = smooth_simulation(&identification.model, measured) else {
                continue;
            };
            overlay_data.push(series(measured));
            overlay_model.push(series(&smooth.trajectory));
            let model_points: Vec<&[f64]> =
                smooth.trajectory.states().chunks_exact(S::DIM).collect();
            let title = format!(
                "Trajectory {}: model (blue) vs measured (black)",
                trajectory_label(measured)
            );
            for &(a, b) in &pairs {
                let name = if S::DIM == 2 {
                    format!("validation_{}.png", number + 1)
                } else {
                    format!("validation_{}_{}_{}.png", number + 1, names[a], names[b])
                };
                let model_xy: Vec<[f64; 2]> = model_points.iter().map(|x| [x[a], x[b]]).collect();
                let measured_xy: Vec<(f64, f64)> = measured
                    .states()
                    .chunks_exact(S::DIM)
                    .map(|x| (x[a], x[b]))
                    .collect();
                attempt(name, &|path| {
                    phase_portrait_2d(
                        path,
                        &[&model_xy],
                        &measured_xy,
                        &Labels {
                            title: &title,
                            x: names[a],
                            y: names[b],
                            reference: "measured states",
                            ..Labels::default()
                        },
                    )
                })?;
            }
        }
        if !overlay_data.is_empty() {
            attempt("validation_overlay.png".to_owned(), &|path| {
                trajectory_overlay(
                    path,
                    &overlay_data,
                    &overlay_model,
                    names,
                    &Labels {
                        title: "Validation trajectories: measured (markers) and model (lines)",
                        x: "t",
                        ..Labels::default()
                    },
                )
            })?;
        }
        if S::DIM == 3 && !checked.simulations.is_empty() {
            let trajectories: Vec<Vec<&[f64]>> = checked
                .simulations
                .iter()
                .map(|(_, s)| s.trajectory.states().chunks_exact(3).collect())
                .collect();
            attempt("model_trajectories_3d.png".to_owned(), &|path| {
                trajectories_3d(
                    path,
                    &trajectories,
                    None,
                    &Labels {
                        title: "Model from the validation trajectories' first states",
                        x: names[0],
                        y: names[1],
                        z: names[2],
                        ..Labels::default()
                    },
                )
            })?;
        }
        let history = &identification.history;
        if !history.iterations.is_empty() {
            attempt("loss.png".to_owned(), &|path| {
                crate::figures::loss_figure(
                    path,
                    history,
                    "Training loss (mean |residual| per component)",
                )
            })?;
        }
        if !checked.simulations.is_empty() {
            let simulations: Vec<&Simulation> =
                checked.simulations.iter().map(|(_, s)| s).collect();
            attempt("free_energy.png".to_owned(), &|path| {
                crate::figures::free_energy_figure(
                    path,
                    &simulations,
                    "Free energy along the model's validation trajectories",
                )
            })?;
        }
        Ok(())
    }
}

/// Writes `out/name` whole or not at all (through a temporary file),
/// refusing to replace a file unless `overwrite`.
pub(super) fn write_output(
    out: &Path,
    name: &str,
    bytes: &[u8],
    overwrite: bool,
) -> Result<(), FromCsvError> {
    let path = out.join(name);
    let mode = if overwrite {
        WriteMode::Overwrite
    } else {
        WriteMode::CreateNew
    };
    write_file(&path, bytes, mode).map_err(|err| match err {
        metriplectic_runtime::Error::FileExists { path } => FromCsvError::OutputExists(path),
        other => other.into(),
    })
}
