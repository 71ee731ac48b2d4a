//! Tests of the `plot` feature: every figure is written as a valid PNG and
//! SVG from synthetic data shaped like the paper's, and bad paths and bad data
//! are rejected with the right typed error before anything is written; axis
//! labels are readable (at least 3 on a log axis, whole numbers on iteration
//! axes).
//!
//! Set `METRIPLECTIC_PLOT_DIR=/some/dir` to keep the rendered figures there
//! for inspection; by default they go to a scratch directory that is removed.

use std::f64::consts::TAU;
use std::path::{Path, PathBuf};

use metriplectic_runtime::Error;
use metriplectic_runtime::{
    free_energy_curves, integer_axis_ticks, log_axis_ticks, loss_curves, phase_portrait_2d,
    trajectories_3d, trajectory_overlay, Labels, PlotError,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A fresh output directory for one test.
struct OutDir {
    path: PathBuf,
    keep: bool,
}

impl OutDir {
    fn new(test: &str) -> Self {
        let (path, keep) = match std::env::var_os("METRIPLECTIC_PLOT_DIR") {
            Some(dir) => (PathBuf::from(dir), true),
            None => (
                std::env::temp_dir()
                    .join(format!("metriplectic-plot-{}-{test}", std::process::id())),
                false,
            ),
        };
        std::fs::create_dir_all(&path).unwrap();
        OutDir { path, keep }
    }

    fn file(&self, name: &str) -> PathBuf {
        self.path.join(name)
    }
}

impl Drop for OutDir {
    fn drop(&mut self) {
        if !self.keep {
            let _ = std::fs::remove_dir_all(&self.path);
        }
    }
}

const PNG_SIGNATURE: [u8; 8] = [0x89, b'P', b'N', b'G', b'\r', b'\n', 0x1a, b'\n'];

/// Decodes the PNG and returns (width, height, number of distinct colours).
fn check_png(path: &Path) -> (u32, u32, usize) {
    let bytes = std::fs::read(path).unwrap();
    assert_eq!(bytes[..8], PNG_SIGNATURE, "{} is not a PNG", path.display());
    let decoder = png::Decoder::new(std::io::Cursor::new(&bytes));
    let mut reader = decoder.read_info().unwrap();
    let mut pixels = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut pixels).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgb);
    let mut colours: Vec<[u8; 3]> = pixels[..info.buffer_size()]
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    colours.sort_unstable();
    colours.dedup();
    (info.width, info.height, colours.len())
}

/// Returns the SVG text after checking it is a well-formed-looking SVG document.
fn check_svg(path: &Path) -> String {
    let text = std::fs::read_to_string(path).unwrap();
    assert!(
        text.contains("<svg"),
        "{} has no <svg element",
        path.display()
    );
    assert!(
        text.trim_end().ends_with("</svg>"),
        "{} is not closed",
        path.display()
    );
    assert_eq!(
        text.matches("<svg").count(),
        text.matches("</svg>").count(),
        "unbalanced svg elements"
    );
    text
}

/// Point of the figure eight (cos t, sin 2t), the zero set of the 2-D free energy.
fn eight(t: f64) -> [f64; 2] {
    [t.cos(), (2.0 * t).sin()]
}

/// 200 planar curves from random starts that wind onto the figure eight.
fn planar_trajectories(rng: &mut ChaCha8Rng) -> Vec<Vec<[f64; 2]>> {
    (0..200)
        .map(|_| {
            let start = [rng.random_range(-1.6..1.6), rng.random_range(-1.6..1.6)];
            let phase = rng.random_range(0.0..TAU);
            let anchor = eight(phase);
            (0..400)
                .map(|i| {
                    let t = 0.02 * i as f64;
                    let on = eight(phase + 0.8 * t);
                    let decay = (-0.9 * t).exp();
                    [
                        on[0] + (start[0] - anchor[0]) * decay,
                        on[1] + (start[1] - anchor[1]) * decay,
                    ]
                })
                .collect()
        })
        .collect()
}

/// Curves from random starts in a ball converging radially onto the unit sphere
/// while turning about the vertical axis.
fn spatial_trajectories(rng: &mut ChaCha8Rng, count: usize) -> Vec<Vec<Vec<f64>>> {
    (0..count)
        .map(|_| {
            let v: [f64; 3] = std::array::from_fn(|_| rng.random_range(-1.0..1.0));
            let norm = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt().max(1e-3);
            let r0 = rng.random_range(0.3..1.7);
            (0..300)
                .map(|i| {
                    let t = 0.02 * i as f64;
                    let r = 1.0 + (r0 - 1.0) * (-1.5 * t).exp();
                    let (c, s) = ((0.4 * t).cos(), (0.4 * t).sin());
                    let (x, y, z) = (v[0] / norm, v[1] / norm, v[2] / norm);
                    vec![r * (c * x - s * y), r * (s * x + c * y), r * z]
                })
                .collect()
        })
        .collect()
}

fn eight_curve() -> Vec<(f64, f64)> {
    (0..=600)
        .map(|i| {
            let [q, p] = eight(TAU * i as f64 / 600.0);
            (q, p)
        })
        .collect()
}

fn planar_labels() -> Labels<'static> {
    Labels {
        title: "2-D metriplectic system: trajectories",
        x: "q",
        y: "p",
        reference: "zero set of E: (cos t, sin 2t)",
        ..Labels::default()
    }
}

#[test]
fn phase_portrait_writes_png_and_svg() {
    let out = OutDir::new("phase");
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let trajectories = planar_trajectories(&mut rng);
    let zero_set = eight_curve();

    let png = out.file("phase_portrait.png");
    phase_portrait_2d(&png, &trajectories, &zero_set, &planar_labels()).unwrap();
    let (w, h, colours) = check_png(&png);
    assert!(w >= 800 && h >= 800, "{w}x{h}");
    // Lines, dots, text and anti-aliasing give many colours; a blank or
    // single-colour image would have 1–2.
    assert!(colours > 50, "only {colours} colours");

    let svg = out.file("phase_portrait.svg");
    phase_portrait_2d(&svg, &trajectories, &zero_set, &planar_labels()).unwrap();
    let text = check_svg(&svg);
    assert!(text.contains("zero set of E"), "legend missing");
    // One red start dot per trajectory.
    assert!(text.matches("<circle").count() >= trajectories.len());

    // Drawn again over the same files: replaced through a temporary file
    // and a rename, so nothing but the two figures is left in the directory.
    phase_portrait_2d(&png, &trajectories, &zero_set, &planar_labels()).unwrap();
    phase_portrait_2d(&svg, &trajectories, &zero_set, &planar_labels()).unwrap();
    check_png(&png);
    let mut names: Vec<String> = std::fs::read_dir(png.parent().unwrap())
        .unwrap()
        .map(|entry| entry.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["phase_portrait.png", "phase_portrait.svg"]);
}

#[test]
fn trajectories_3d_writes_png_and_svg() {
    let out = OutDir::new("sphere");
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let trajectories = spatial_trajectories(&mut rng, 120);
    let labels = Labels {
        title: "SO(3) rigid body: trajectories",
        x: "p_x",
        y: "p_y",
        z: "p_z",
        reference: "unit sphere (E = 0)",
    };
    let png = out.file("trajectories_3d.png");
    trajectories_3d(&png, &trajectories, Some(1.0), &labels).unwrap();
    let (w, h, colours) = check_png(&png);
    assert!(w >= 800 && h >= 800, "{w}x{h}");
    assert!(colours > 50, "only {colours} colours");

    let svg = out.file("trajectories_3d.svg");
    trajectories_3d(&svg, &trajectories, None, &labels).unwrap();
    let text = check_svg(&svg);
    assert!(
        !text.contains("unit sphere"),
        "sphere drawn although not asked for"
    );
    assert!(text.contains("p_z"));
}

#[test]
fn loss_curves_write_png_and_svg_and_note_clamped_zeros() {
    let out = OutDir::new("loss");
    // Superlinear decrease like the paper's Fig. 2, with chattering; the
    // entropy cost reaches exactly 0 at the end (drawn at the floor).
    let metric: Vec<f64> = (0..700)
        .map(|k| {
            let k = k as f64;
            10f64.powf(-0.012 * k - 1e-5 * k * k) * (1.0 + 0.3 * (0.7 * k).sin())
        })
        .collect();
    let mut entropy: Vec<f64> = metric.iter().map(|v| 0.6 * v).collect();
    entropy[690..].iter_mut().for_each(|v| *v = 0.0);
    let labels = Labels {
        title: "2-D system: loss of Algorithm 2",
        x: "iteration",
        y: "cost per residual component",
        ..Labels::default()
    };
    let series = [
        ("metric search", &metric[..]),
        ("entropy search", &entropy[..]),
    ];

    let png = out.file("loss.png");
    loss_curves(&png, &series, &labels).unwrap();
    let (_, _, colours) = check_png(&png);
    assert!(colours > 20, "only {colours} colours");

    let svg = out.file("loss.svg");
    loss_curves(&svg, &series, &labels).unwrap();
    let text = check_svg(&svg);
    assert!(text.contains("metric search") && text.contains("entropy search"));
    assert!(
        text.contains("values ≤ 0 drawn at"),
        "clamping note missing"
    );

    // Without zeros there is no note.
    let positive = [("metric search", &metric[..])];
    let svg = out.file("loss_positive.svg");
    loss_curves(&svg, &positive, &labels).unwrap();
    assert!(!check_svg(&svg).contains("values ≤ 0"));
}

/// Free energies that do not end at 0: each curve levels off at its own
/// limit (an identified E is only defined up to a constant), some above 0,
/// some below.
#[test]
fn free_energy_curves_write_png_and_svg() {
    let out = OutDir::new("energy");
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let curves: Vec<(Vec<f64>, Vec<f64>)> = (0..200)
        .map(|_| {
            let limit = rng.random_range(-50.0..50.0);
            let e0 = rng.random_range(1e-3..2.0);
            let rate = rng.random_range(1.0..3.0);
            let times: Vec<f64> = (0..=200).map(|i| 0.05 * i as f64).collect();
            let energy = times
                .iter()
                .map(|t| limit - e0 * (-rate * t).exp())
                .collect();
            (times, energy)
        })
        .collect();
    let labels = Labels {
        title: "free energy along simulated trajectories",
        x: "time t",
        y: "E_lim − E",
        ..Labels::default()
    };
    let png = out.file("free_energy.png");
    free_energy_curves(&png, &curves, &labels).unwrap();
    let (_, _, colours) = check_png(&png);
    assert!(colours > 20, "only {colours} colours");
    let svg = out.file("free_energy.svg");
    free_energy_curves(&svg, &curves, &labels).unwrap();
    let text = check_svg(&svg);
    assert!(text.contains("E_lim − E"));
    assert!(
        text.contains("E_lim = the limit of E along it"),
        "convention note missing"
    );
    // A directory where the figure goes: one "invalid …", not two.
    let directory = out.file("a_directory.svg");
    std::fs::create_dir_all(&directory).unwrap();
    let err = free_energy_curves(&directory, &curves, &labels)
        .unwrap_err()
        .to_string();
    assert!(
        err.starts_with("invalid figure path: ") && !err.contains("invalid file path"),
        "{err}"
    );
    // Times that go back are not a trajectory (a probe's were drawn).
    let backwards = [(vec![0.0, 2.0, 1.0], vec![-3.0, -2.0, -1.5])];
    let err = free_energy_curves(out.file("backwards.svg"), &backwards, &labels).unwrap_err();
    assert!(
        err.to_string()
            .contains("free-energy curve 0 (times): time 2 (1) does not come after time 1 (2)"),
        "{err}"
    );
}

/// The figure shows E_lim − E: a constant added to a curve (the freedom an
/// identified free energy has) changes nothing, whichever sign it has.
#[test]
fn free_energy_curves_ignore_the_constant_in_e() {
    let out = OutDir::new("energy_constant");
    let labels = Labels::default();
    // Dyadic values: E − E_lim is exact, so the figures must be identical.
    let curve = |offset: f64| -> (Vec<f64>, Vec<f64>) {
        let times: Vec<f64> = (0..20).map(f64::from).collect();
        let energy = (0..20).map(|i| offset - 0.5f64.powi(i)).collect();
        (times, energy)
    };
    let mut texts = Vec::new();
    for (name, offset) in [("zero", 0.0), ("above", 1024.0), ("below", -4096.0)] {
        let path = out.file(&format!("energy_{name}.svg"));
        free_energy_curves(&path, &[curve(offset), curve(offset / 2.0)], &labels).unwrap();
        texts.push(check_svg(&path));
    }
    assert_eq!(texts[0], texts[1]);
    assert_eq!(texts[0], texts[2]);
}

fn plot_error(result: metriplectic_runtime::Result<()>) -> PlotError {
    match result {
        Err(Error::Plot(err)) => err,
        other => panic!("expected a plot error, got {other:?}"),
    }
}

#[test]
fn unsupported_extensions_are_rejected_before_writing() {
    let out = OutDir::new("ext");
    let traj = vec![vec![[0.0, 0.0], [1.0, 1.0]]];
    let labels = Labels::default();
    for name in ["figure.jpg", "figure", "figure.png.txt"] {
        let path = out.file(name);
        let err = plot_error(phase_portrait_2d(&path, &traj, &[], &labels));
        assert!(
            matches!(&err, PlotError::UnsupportedFormat { path: p } if p == &path),
            "{name}: {err}"
        );
        assert!(err.to_string().contains(".png or .svg"));
        assert!(!path.exists());
    }
    // Upper-case extensions are accepted.
    let upper = out.file("figure.SVG");
    phase_portrait_2d(&upper, &traj, &[], &labels).unwrap();
    check_svg(&upper);

    let spatial = vec![vec![[0.0, 0.0, 0.0]]];
    let series = [("a", &[1.0][..])];
    let pairs = [(vec![0.0], vec![-1.0])];
    let bmp = out.file("figure.bmp");
    assert!(matches!(
        plot_error(trajectories_3d(&bmp, &spatial, Some(1.0), &labels)),
        PlotError::UnsupportedFormat { .. }
    ));
    assert!(matches!(
        plot_error(loss_curves(&bmp, &series, &labels)),
        PlotError::UnsupportedFormat { .. }
    ));
    assert!(matches!(
        plot_error(free_energy_curves(&bmp, &pairs, &labels)),
        PlotError::UnsupportedFormat { .. }
    ));
}

#[test]
fn bad_trajectories_are_rejected_with_their_position() {
    let out = OutDir::new("badtraj");
    let path = out.file("bad.png");
    let labels = Labels::default();

    let none: Vec<Vec<[f64; 2]>> = vec![];
    assert!(matches!(
        plot_error(phase_portrait_2d(&path, &none, &[], &labels)),
        PlotError::Empty { .. }
    ));
    let empty_one: Vec<Vec<[f64; 2]>> = vec![vec![[0.0, 1.0]], vec![]];
    match plot_error(phase_portrait_2d(&path, &empty_one, &[], &labels)) {
        PlotError::Empty { what } => assert_eq!(what, "trajectory 1"),
        other => panic!("{other}"),
    }
    let wrong_dim = vec![vec![vec![0.0, 1.0], vec![0.0, 1.0, 2.0]]];
    match plot_error(phase_portrait_2d(&path, &wrong_dim, &[], &labels)) {
        PlotError::PointDimension {
            trajectory: 0,
            point: 1,
            expected: 2,
            found: 3,
        } => {}
        other => panic!("{other}"),
    }
    let nan = vec![
        vec![[0.0, 1.0]],
        vec![[0.0, 1.0], [2.0, 2.0], [f64::NAN, 0.0]],
    ];
    match plot_error(phase_portrait_2d(&path, &nan, &[], &labels)) {
        PlotError::NonFinite { what, index, value } => {
            assert_eq!((what.as_str(), index), ("trajectory 1", 2));
            assert!(value.is_nan());
        }
        other => panic!("{other}"),
    }
    let ok = vec![vec![[0.0, 1.0]]];
    match plot_error(phase_portrait_2d(
        &path,
        &ok,
        &[(0.0, 0.0), (f64::INFINITY, 1.0)],
        &labels,
    )) {
        PlotError::NonFinite {
            what,
            index: 1,
            value,
        } => {
            assert_eq!(what, "zero set");
            assert_eq!(value, f64::INFINITY);
        }
        other => panic!("{other}"),
    }

    let planar_in_3d = vec![vec![[0.0, 1.0]]];
    assert!(matches!(
        plot_error(trajectories_3d(&path, &planar_in_3d, Some(1.0), &labels)),
        PlotError::PointDimension {
            expected: 3,
            found: 2,
            ..
        }
    ));
    let spatial = vec![vec![[0.0, 1.0, 0.5]]];
    for radius in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(matches!(
            plot_error(trajectories_3d(&path, &spatial, Some(radius), &labels)),
            PlotError::InvalidArgument { .. }
        ));
    }
    assert!(!path.exists(), "a rejected figure must not leave a file");
}

#[test]
fn bad_curves_are_rejected_with_their_name() {
    let out = OutDir::new("badcurves");
    let path = out.file("bad.svg");
    let labels = Labels::default();

    assert!(matches!(
        plot_error(loss_curves(&path, &[], &labels)),
        PlotError::Empty { .. }
    ));
    match plot_error(loss_curves(
        &path,
        &[("metric", &[1.0][..]), ("entropy", &[][..])],
        &labels,
    )) {
        PlotError::Empty { what } => assert_eq!(what, "series `entropy`"),
        other => panic!("{other}"),
    }
    match plot_error(loss_curves(
        &path,
        &[("metric", &[1.0, f64::NAN][..])],
        &labels,
    )) {
        PlotError::NonFinite { what, index: 1, .. } => assert_eq!(what, "series `metric`"),
        other => panic!("{other}"),
    }
    assert!(matches!(
        plot_error(loss_curves(&path, &[("metric", &[0.0, -1.0][..])], &labels)),
        PlotError::NoPositiveValues { .. }
    ));

    let mismatched = [(vec![0.0, 1.0], vec![-1.0])];
    assert!(matches!(
        plot_error(free_energy_curves(&path, &mismatched, &labels)),
        PlotError::LengthMismatch {
            left: 2,
            right: 1,
            ..
        }
    ));
    let bad_time = [(vec![0.0, f64::NAN], vec![-1.0, -0.5])];
    match plot_error(free_energy_curves(&path, &bad_time, &labels)) {
        PlotError::NonFinite { what, index: 1, .. } => {
            assert_eq!(what, "free-energy curve 0 (times)")
        }
        other => panic!("{other}"),
    }
    // E constant along every curve: E_lim − E is never positive, nothing
    // to show on a log axis.
    let flat = [(vec![0.0, 1.0], vec![1.0, 1.0]), (vec![0.0], vec![-3.0])];
    assert!(matches!(
        plot_error(free_energy_curves(&path, &flat, &labels)),
        PlotError::NoPositiveValues { .. }
    ));
    assert!(!path.exists(), "a rejected figure must not leave a file");
}

#[test]
fn unwritable_path_is_an_io_error_naming_it() {
    let out = OutDir::new("io");
    let path = out.file("missing-dir").join("figure.png");
    let series = [("metric", &[1.0, 0.1][..])];
    match plot_error(loss_curves(&path, &series, &Labels::default())) {
        PlotError::Io { path: p, .. } => assert_eq!(p, path),
        other => panic!("{other}"),
    }
}

#[test]
fn degenerate_but_valid_data_still_renders() {
    let out = OutDir::new("degenerate");
    let labels = Labels::default();
    // A single state, no reference curve.
    let point = vec![vec![[0.0, 0.0]]];
    let path = out.file("single_point.png");
    phase_portrait_2d(&path, &point, &[], &labels).unwrap();
    check_png(&path);
    // A tight cluster far from the origin.
    let far = vec![vec![[1e6, -1e6], [1e6 + 1e-4, -1e6]]];
    let path = out.file("far_cluster.svg");
    phase_portrait_2d(&path, &far, &[], &labels).unwrap();
    check_svg(&path);
    // The origin only, no sphere.
    let origin = vec![vec![[0.0, 0.0, 0.0]]];
    let path = out.file("origin_3d.png");
    trajectories_3d(&path, &origin, None, &labels).unwrap();
    check_png(&path);
    // One iteration; one time stamp far from 0.
    let path = out.file("one_iteration.png");
    loss_curves(&path, &[("cost", &[3e-7][..])], &labels).unwrap();
    check_png(&path);
    // A one-sample free-energy curve (nothing to show on its own) beside a
    // decaying one, both far from t = 0.
    let path = out.file("one_time.svg");
    let curves = [
        (vec![1e9], vec![-2.0]),
        (vec![1e9, 1e9 + 1.0], vec![-2.0, 5.0]),
    ];
    free_energy_curves(&path, &curves, &labels).unwrap();
    check_svg(&path);
}

#[test]
fn coordinates_too_large_to_lay_out_are_rejected() {
    let out = OutDir::new("huge");
    let labels = Labels::default();
    let path = out.file("huge.png");
    let huge = vec![vec![[-1e308, 0.0], [1e308, 1.0]]];
    assert!(matches!(
        plot_error(phase_portrait_2d(&path, &huge, &[], &labels)),
        PlotError::InvalidArgument { .. }
    ));
    let huge = vec![vec![[0.0, 1e308, 0.0]]];
    assert!(matches!(
        plot_error(trajectories_3d(&path, &huge, Some(1.0), &labels)),
        PlotError::InvalidArgument { .. }
    ));
    // A sphere too large to lay out, around small data: refused, where
    // plotters' key points looped forever on an infinite axis width.
    let small = vec![vec![[0.0, 0.0, 1.0]]];
    assert!(matches!(
        plot_error(trajectories_3d(&path, &small, Some(1e308), &labels)),
        PlotError::InvalidArgument { .. }
    ));
    let huge_times = [(vec![-1e308, 1e308], vec![-1.0, -0.5])];
    assert!(matches!(
        plot_error(free_energy_curves(&path, &huge_times, &labels)),
        PlotError::InvalidArgument { .. }
    ));
    assert!(!path.exists());
}

/// The text of every `<text>` element of an SVG, in order.
fn svg_texts(svg: &str) -> Vec<String> {
    svg.split("<text")
        .skip(1)
        .filter_map(|chunk| {
            let start = chunk.find('>')? + 1;
            let end = chunk.find("</text>")?;
            Some(chunk[start..end].trim().to_owned())
        })
        .collect()
}

/// A log axis within one decade still gets at least 3 labels (plotters' own
/// ticks gave one), all inside the range, increasing.
#[test]
fn log_axis_ticks_label_narrow_ranges() {
    for (low, high) in [
        (1e-3, 1e-2),
        (2e-3, 8e-3),
        (0.3, 0.9),
        (1.0, 10.0),
        (0.81, 0.89),
        (7e-9, 9e-9),
        (1e-14, 1.0),
        (3e4, 2e7),
    ] {
        let ticks = log_axis_ticks(low, high).unwrap();
        let labels: Vec<&str> = ticks.iter().map(|t| t.label.as_str()).collect();
        assert!(
            (3..=10).contains(&ticks.len()),
            "[{low:e}, {high:e}]: {labels:?}"
        );
        assert!(
            ticks
                .iter()
                .all(|t| t.value >= low * (1.0 - 1e-9) && t.value <= high * (1.0 + 1e-9)),
            "[{low:e}, {high:e}]: {ticks:?}"
        );
        assert!(ticks.windows(2).all(|w| w[0].value < w[1].value));
        assert!(labels.iter().all(|l| !l.is_empty()));
    }
    assert!(matches!(
        log_axis_ticks(0.0, 1.0),
        Err(Error::Plot(PlotError::InvalidArgument { .. }))
    ));

    // In a figure: costs between 0.2 and 0.9 label 10⁻¹, 2×10⁻¹, 5×10⁻¹, 10⁰.
    let out = OutDir::new("ticks_log");
    let path = out.file("one_decade.svg");
    let costs = [0.9, 0.7, 0.5, 0.35, 0.3, 0.2];
    loss_curves(&path, &[("cost", &costs[..])], &Labels::default()).unwrap();
    let texts = svg_texts(&check_svg(&path));
    for label in ["10⁻¹", "2×10⁻¹", "5×10⁻¹", "10⁰"] {
        assert!(
            texts.iter().any(|t| t == label),
            "{label} missing: {texts:?}"
        );
    }
}

/// Iteration axes are labelled at whole numbers only, however few or many
/// iterations there are.
#[test]
fn integer_axis_ticks_have_no_fractions() {
    for (low, high) in [
        (0.5, 1.5),
        (1.0, 2.0),
        (1.0, 3.0),
        (0.5, 4.5),
        (1.0, 7.0),
        (1.0, 12.0),
        (1.0, 37.0),
        (1.0, 700.0),
        (3.0, 123_456.0),
    ] {
        let ticks = integer_axis_ticks(low, high).unwrap();
        assert!(
            !ticks.is_empty() && ticks.len() <= 10,
            "[{low}, {high}]: {ticks:?}"
        );
        for tick in &ticks {
            assert_eq!(tick.value.fract(), 0.0, "[{low}, {high}]: {ticks:?}");
            assert!(tick.value >= low && tick.value <= high);
            assert_eq!(tick.label.parse::<f64>().unwrap(), tick.value);
        }
    }
    assert_eq!(integer_axis_ticks(1.0, 3.0).unwrap().len(), 3);

    // In a figure: 3 iterations are labelled 1, 2, 3 and nothing between.
    let out = OutDir::new("ticks_int");
    let path = out.file("three_iterations.svg");
    let costs = [1.0, 0.1, 0.01];
    loss_curves(&path, &[("cost", &costs[..])], &Labels::default()).unwrap();
    let texts = svg_texts(&check_svg(&path));
    for label in ["1", "2", "3"] {
        assert!(
            texts.iter().any(|t| t == label),
            "{label} missing: {texts:?}"
        );
    }
    assert!(
        !texts
            .iter()
            .any(|t| t.contains('.') && t.parse::<f64>().is_ok()),
        "fractional tick: {texts:?}"
    );
}

/// Trajectories as `trajectory_overlay` takes them: (times, states).
type Series = Vec<(Vec<f64>, Vec<Vec<f64>>)>;

/// Three state variables, four trajectories: noisy samples against smooth
/// model curves.
fn overlay_data() -> (Series, Series) {
    let mut rng = ChaCha8Rng::seed_from_u64(8);
    let state = |k: usize, t: f64| {
        let phase = k as f64;
        vec![
            (t + phase).cos() * (-0.2 * t).exp(),
            (t + phase).sin() * (-0.2 * t).exp(),
            1.0 + 0.1 * k as f64 - (-t).exp(),
        ]
    };
    let data = (0..4)
        .map(|k| {
            let times: Vec<f64> = (0..40).map(|i| 0.25 * i as f64).collect();
            let states = times
                .iter()
                .map(|&t| {
                    state(k, t)
                        .into_iter()
                        .map(|x| x + rng.random_range(-0.03..0.03))
                        .collect()
                })
                .collect();
            (times, states)
        })
        .collect();
    let model = (0..4)
        .map(|k| {
            let times: Vec<f64> = (0..400).map(|i| 0.025 * i as f64).collect();
            let states = times.iter().map(|&t| state(k, t)).collect();
            (times, states)
        })
        .collect();
    (data, model)
}

#[test]
fn trajectory_overlay_writes_png_and_svg() {
    let out = OutDir::new("overlay");
    let (data, model) = overlay_data();
    let names = ["q", "p", "s"];
    let labels = Labels {
        title: "held-out trajectories: data and model",
        x: "t",
        ..Labels::default()
    };
    let png = out.file("overlay.png");
    trajectory_overlay(&png, &data, &model, &names, &labels).unwrap();
    let (w, h, colours) = check_png(&png);
    assert!(w >= 800 && h >= 3 * 200, "{w}x{h}");
    assert!(colours > 50, "only {colours} colours");

    let svg = out.file("overlay.svg");
    trajectory_overlay(&svg, &data, &model, &names, &labels).unwrap();
    let text = check_svg(&svg);
    let texts = svg_texts(&text);
    for label in ["q", "p", "s", "t", "data", "model", "trajectory:", "0", "3"] {
        assert!(
            texts.iter().any(|t| t == label),
            "{label} missing: {texts:?}"
        );
    }
    // One marker per data sample and state variable, plus the legend's.
    assert!(text.matches("<circle").count() >= 4 * 40 * 3);

    // Data alone, and fixed-size arrays as states.
    let svg = out.file("overlay_data_only.svg");
    let arrays: Vec<(Vec<f64>, Vec<[f64; 2]>)> = vec![(
        vec![0.0, 1.0, 2.0],
        vec![[0.0, 1.0], [0.5, 0.8], [0.7, 0.7]],
    )];
    trajectory_overlay(&svg, &arrays, &[], &["x", "y"], &Labels::default()).unwrap();
    assert!(!svg_texts(&check_svg(&svg)).iter().any(|t| t == "model"));
}

/// The legend has a band of its own above the panels: every data marker
/// lies below it.
#[test]
fn trajectory_overlay_legend_does_not_cover_the_data() {
    let out = OutDir::new("overlay_legend");
    let (data, model) = overlay_data();
    let svg = out.file("overlay.svg");
    trajectory_overlay(&svg, &data, &model, &["q", "p", "s"], &Labels::default()).unwrap();
    let text = check_svg(&svg);
    let attribute = |element: &str, name: &str| -> Option<f64> {
        let start = element.find(&format!(" {name}=\""))? + name.len() + 3;
        let end = start + element[start..].find('"')?;
        element[start..end].parse().ok()
    };
    let legend_y = text
        .split("<text")
        .skip(1)
        .find(|chunk| {
            let content = chunk.split_once('>').map(|(_, rest)| rest);
            content.is_some_and(|rest| rest.trim_start().starts_with("data\n"))
        })
        .and_then(|chunk| attribute(chunk, "y"))
        .expect("legend entry `data`");
    let marker_y: Vec<f64> = text
        .split("<circle")
        .skip(1)
        .filter_map(|chunk| attribute(chunk, "cy"))
        .collect();
    // The legend's own marker sits on the legend's line; all others below.
    let below = marker_y.iter().filter(|&&y| y > legend_y + 20.0).count();
    assert_eq!(
        below + 1,
        marker_y.len(),
        "legend at {legend_y}: {marker_y:?}"
    );
}

#[test]
fn trajectory_overlay_rejects_mismatched_states() {
    let out = OutDir::new("overlay_bad");
    let path = out.file("bad.png");
    let labels = Labels::default();
    let (data, model) = overlay_data();
    let names = ["q", "p", "s"];

    let mut short = data.clone();
    short[1].1[4].pop();
    match plot_error(trajectory_overlay(&path, &short, &model, &names, &labels)) {
        PlotError::StateDimension {
            what,
            sample: 4,
            expected: 3,
            found: 2,
        } => assert_eq!(what, "data trajectory 1"),
        other => panic!("{other}"),
    }
    let mut long = model.clone();
    long[2].1[0].push(0.0);
    let err = plot_error(trajectory_overlay(&path, &data, &long, &names, &labels));
    assert!(
        matches!(
            &err,
            PlotError::StateDimension { what, sample: 0, expected: 3, found: 4 }
                if what == "model trajectory 2"
        ),
        "{err}"
    );
    assert!(err
        .to_string()
        .contains("model trajectory 2, sample 0: 4 components"));
    // Two names for three-component states.
    assert!(matches!(
        plot_error(trajectory_overlay(
            &path,
            &data,
            &model,
            &["q", "p"],
            &labels
        )),
        PlotError::StateDimension {
            expected: 2,
            found: 3,
            ..
        }
    ));

    assert!(matches!(
        plot_error(trajectory_overlay(
            &path,
            &data,
            &model[..3],
            &names,
            &labels
        )),
        PlotError::InvalidArgument { .. }
    ));
    let mut nan = data.clone();
    nan[0].1[7][2] = f64::NAN;
    match plot_error(trajectory_overlay(&path, &nan, &model, &names, &labels)) {
        PlotError::NonFinite { what, index: 7, .. } => {
            assert_eq!(what, "data trajectory 0, state `s`")
        }
        other => panic!("{other}"),
    }
    let mut uneven = data.clone();
    uneven[3].0.pop();
    assert!(matches!(
        plot_error(trajectory_overlay(&path, &uneven, &model, &names, &labels)),
        PlotError::LengthMismatch {
            left: 39,
            right: 40,
            ..
        }
    ));
    let none: Series = Vec::new();
    assert!(matches!(
        plot_error(trajectory_overlay(&path, &none, &none, &names, &labels)),
        PlotError::Empty { .. }
    ));
    assert!(matches!(
        plot_error(trajectory_overlay(&path, &data, &model, &[], &labels)),
        PlotError::Empty { .. }
    ));
    let many = ["x"; 13];
    assert!(matches!(
        plot_error(trajectory_overlay(&path, &data, &model, &many, &labels)),
        PlotError::InvalidArgument { .. }
    ));
    assert!(matches!(
        plot_error(trajectory_overlay(
            out.file("bad.jpg"),
            &data,
            &model,
            &names,
            &labels
        )),
        PlotError::UnsupportedFormat { .. }
    ));
    assert!(!path.exists(), "a rejected figure must not leave a file");
}

/// Log-axis ranges at the ends of f64: adjacent subnormal bounds end (their
/// step exponent once overflowed), and a range up to f64::MAX has no tick
/// at infinity labelled 10³⁰⁹.
#[test]
fn log_ticks_at_the_ends_of_the_float_range_are_finite_and_end() {
    let tiny = log_axis_ticks(f64::from_bits(100), f64::from_bits(101)).unwrap();
    assert!(tiny.iter().all(|t| t.value.is_finite()), "{tiny:?}");
    let top = log_axis_ticks(1e305, f64::MAX).unwrap();
    assert!(!top.is_empty());
    assert!(
        top.iter()
            .all(|t| t.value.is_finite() && t.value <= f64::MAX),
        "{top:?}"
    );
}
