//! Validation of plain input data and the log-scale floor.

use super::PlotError;

/// Copies trajectories of `dim`-dimensional points after checking that there
/// is at least one, none is empty, every point has `dim` finite components.
pub(crate) fn trajectories<T, P>(
    trajectories: &[T],
    dim: usize,
) -> Result<Vec<Vec<Vec<f64>>>, PlotError>
where
    T: AsRef<[P]>,
    P: AsRef<[f64]>,
{
    if trajectories.is_empty() {
        return Err(PlotError::Empty {
            what: "the list of trajectories".to_owned(),
        });
    }
    trajectories
        .iter()
        .enumerate()
        .map(|(k, trajectory)| {
            let points = trajectory.as_ref();
            if points.is_empty() {
                return Err(PlotError::Empty {
                    what: format!("trajectory {k}"),
                });
            }
            points
                .iter()
                .enumerate()
                .map(|(i, point)| {
                    let x = point.as_ref();
                    if x.len() != dim {
                        return Err(PlotError::PointDimension {
                            trajectory: k,
                            point: i,
                            expected: dim,
                            found: x.len(),
                        });
                    }
                    if let Some(&value) = x.iter().find(|v| !v.is_finite()) {
                        return Err(PlotError::NonFinite {
                            what: format!("trajectory {k}"),
                            index: i,
                            value,
                        });
                    }
                    Ok(x.to_vec())
                })
                .collect()
        })
        .collect()
}

/// Checks that every value of `values` is finite.
pub(crate) fn finite(what: &str, values: &[f64]) -> Result<(), PlotError> {
    match values.iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(index) => Err(PlotError::NonFinite {
            what: what.to_owned(),
            index,
            value: values[index],
        }),
    }
}

/// Checks that `times` (finite) increase: curves over time are drawn in
/// that order, and one that goes back in time is not a trajectory.
pub(crate) fn increasing(what: &str, times: &[f64]) -> Result<(), PlotError> {
    match times.windows(2).position(|t| t[1] <= t[0]) {
        None => Ok(()),
        Some(k) => Err(PlotError::InvalidArgument {
            what: what.to_owned(),
            reason: format!(
                "time {} ({}) does not come after time {k} ({}); times must increase",
                k + 1,
                times[k + 1],
                times[k]
            ),
        }),
    }
}

/// Checks that every coordinate of a planar curve is finite.
pub(crate) fn finite_pairs(what: &str, points: &[(f64, f64)]) -> Result<(), PlotError> {
    match points
        .iter()
        .position(|(x, y)| !x.is_finite() || !y.is_finite())
    {
        None => Ok(()),
        Some(index) => {
            let (x, y) = points[index];
            Err(PlotError::NonFinite {
                what: what.to_owned(),
                index,
                value: if x.is_finite() { y } else { x },
            })
        }
    }
}

/// The smallest interval holding `values` (infinite bounds for none).
pub(crate) fn bounds(values: impl Iterator<Item = f64>) -> (f64, f64) {
    values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
        (lo.min(v), hi.max(v))
    })
}

/// Checks that an axis from `low` to `high` can be laid out: padding and
/// label positions multiply bounds and spans by small factors, which must not
/// overflow to infinity (plotters cannot draw infinite ranges).
pub(crate) fn drawable_span(what: &str, low: f64, high: f64) -> Result<(), PlotError> {
    if (4.0 * low).is_finite() && (4.0 * high).is_finite() && (4.0 * (high - low)).is_finite() {
        Ok(())
    } else {
        Err(PlotError::InvalidArgument {
            what: what.to_owned(),
            reason: format!("values from {low:e} to {high:e} are too large to draw"),
        })
    }
}

/// A logarithmic value axis covering whole decades.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct LogAxis {
    /// Where values ≤ 0 are drawn: one decade below the smallest positive value.
    pub(crate) floor: f64,
    /// Lower end of the axis (a power of ten).
    pub(crate) low: f64,
    /// Upper end of the axis (a power of ten).
    pub(crate) high: f64,
    /// Whether any value was ≤ 0 and is drawn at `floor`.
    pub(crate) clamped: bool,
}

impl LogAxis {
    /// The axis for finite `values`; an error if none is positive.
    pub(crate) fn fit(what: &str, values: impl Iterator<Item = f64>) -> Result<Self, PlotError> {
        let (mut min_pos, mut max, mut clamped) = (f64::INFINITY, f64::NEG_INFINITY, false);
        for v in values {
            if v > 0.0 {
                min_pos = min_pos.min(v);
                max = max.max(v);
            } else {
                clamped = true;
            }
        }
        if !min_pos.is_finite() {
            return Err(PlotError::NoPositiveValues {
                what: what.to_owned(),
            });
        }
        let floor = (min_pos / 10.0).max(f64::MIN_POSITIVE);
        let bottom = if clamped { floor } else { min_pos };
        let low = decade_below(bottom);
        let mut high = decade_above(max);
        if high <= low {
            high = low * 10.0;
        }
        Ok(LogAxis {
            floor,
            low,
            high,
            clamped,
        })
    }

    /// The value to draw for `v`.
    pub(crate) fn clamp(&self, v: f64) -> f64 {
        if v > 0.0 {
            v
        } else {
            self.floor
        }
    }
}

fn decade_below(v: f64) -> f64 {
    10f64.powf(v.log10().floor()).max(f64::MIN_POSITIVE)
}

fn decade_above(v: f64) -> f64 {
    10f64.powf(v.log10().ceil()).min(f64::MAX)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_axis_spans_whole_decades_and_floors_nonpositive_values() {
        let axis = LogAxis::fit("t", [3e-5, 0.2, 0.0, -1.0].into_iter()).unwrap();
        assert!(axis.clamped);
        assert!((axis.floor - 3e-6).abs() < 1e-20);
        assert!((axis.low - 1e-6).abs() < 1e-20);
        assert!((axis.high - 1.0).abs() < 1e-12);
        assert_eq!(axis.clamp(-1.0), axis.floor);
        assert_eq!(axis.clamp(0.2), 0.2);

        let exact = LogAxis::fit("t", [1e-3, 1e-3].into_iter()).unwrap();
        assert!(!exact.clamped);
        assert!(exact.high > exact.low);

        assert!(matches!(
            LogAxis::fit("t", [0.0, -2.0].into_iter()),
            Err(PlotError::NoPositiveValues { .. })
        ));
    }
}
