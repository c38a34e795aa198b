//! Recordings of pulse-steer runs (`cargo xtask lateral_stability --recording FILE`): CSV
//! files from a data logger, read into columns in SI units.
//!
//! The header names each column with its unit in brackets; columns are found by name (any
//! order, case and surrounding spaces ignored), other columns are ignored, lines starting
//! with `#` are comments:
//!
//! | column | units |
//! |---|---|
//! | `time` | `s` |
//! | `speed` | `m/s`, `km/h` |
//! | `steering_angle` | `deg`, `rad` (road-wheel or steering-wheel angle: only its timing is used) |
//! | `hitch_angle` | `deg`, `rad` |
//! | `trailer_yaw_rate` | `deg/s`, `rad/s` |
//! | `car_yaw_rate` | `deg/s`, `rad/s` |
//!
//! `time`, `speed`, `steering_angle` and at least one of the last three are required.
//!
//! ```csv
//! time [s],speed [km/h],steering_angle [deg],hitch_angle [deg]
//! 0.00,100.1,0.0,0.01
//! 0.02,100.0,0.0,0.02
//! ```

use std::path::{Path, PathBuf};

use sway_studies::lateral_stability::DecaySignal;

use crate::TaskError;

/// One recording in SI units (rad, rad/s, m/s), each signal None when the file has no
/// column for it.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordedRun {
    /// the file
    pub file: PathBuf,
    /// t \[s\]
    pub time_s: Vec<f64>,
    /// V \[m/s\]
    pub speed_mps: Vec<f64>,
    /// δ \[rad\]
    pub steering_rad: Vec<f64>,
    /// the signals present, in the order of [`DecaySignal::ALL`] \[rad or rad/s\]
    pub signals: Vec<(DecaySignal, Vec<f64>)>,
    /// the file's line of each sample (1 is the header's), for messages
    pub lines: Vec<u64>,
}

impl RecordedRun {
    /// The signal to read: `preferred` if the file has it, else the first it has.
    pub fn signal(&self, preferred: DecaySignal) -> (DecaySignal, &[f64]) {
        let (s, v) = self
            .signals
            .iter()
            .find(|(s, _)| *s == preferred)
            .unwrap_or(&self.signals[0]);
        (*s, v)
    }

    /// The line of the file holding sample `row` (counted from 0).
    pub fn line(&self, row: usize) -> u64 {
        self.lines.get(row).copied().unwrap_or(0)
    }
}

/// A column of the recording: its name and the units it may be in (with the factor to SI).
struct ColumnSpec {
    name: &'static str,
    units: &'static [(&'static str, f64)],
}

const ANGLE: &[(&str, f64)] = &[("deg", std::f64::consts::PI / 180.0), ("rad", 1.0)];
const RATE: &[(&str, f64)] = &[("deg/s", std::f64::consts::PI / 180.0), ("rad/s", 1.0)];
const TIME: ColumnSpec = ColumnSpec {
    name: "time",
    units: &[("s", 1.0)],
};
const SPEED: ColumnSpec = ColumnSpec {
    name: "speed",
    units: &[("m/s", 1.0), ("km/h", 1.0 / 3.6)],
};
const STEERING: ColumnSpec = ColumnSpec {
    name: "steering_angle",
    units: ANGLE,
};

fn signal_column(s: DecaySignal) -> ColumnSpec {
    ColumnSpec {
        name: s.as_str(),
        units: match s {
            DecaySignal::HitchAngle | DecaySignal::RearmostArticulationAngle => ANGLE,
            DecaySignal::TrailerYawRate | DecaySignal::CarYawRate => RATE,
        },
    }
}

/// A problem of `file` at `place` (a column or a row).
fn problem(file: &Path, place: impl Into<String>, text: impl Into<String>) -> TaskError {
    TaskError::Recording {
        file: file.to_path_buf(),
        place: place.into(),
        problem: text.into(),
    }
}

/// Splits a header cell `name [unit]` into its name and unit.
fn split_header(cell: &str) -> Option<(String, String)> {
    let cell = cell.trim();
    let open = cell.find('[')?;
    let close = cell.rfind(']')?;
    (close > open).then(|| {
        (
            cell[..open].trim().to_lowercase(),
            cell[open + 1..close].trim().to_string(),
        )
    })
}

/// The index and SI factor of `spec`'s column in `header`, None if absent.
fn find_column(
    file: &Path,
    header: &[Option<(String, String)>],
    spec: &ColumnSpec,
) -> Result<Option<(usize, f64)>, TaskError> {
    let Some(i) = header
        .iter()
        .position(|h| h.as_ref().is_some_and(|(n, _)| n == spec.name))
    else {
        return Ok(None);
    };
    let unit = &header[i].as_ref().map(|h| h.1.clone()).unwrap_or_default();
    let factor = spec
        .units
        .iter()
        .find(|(u, _)| u == unit)
        .map(|(_, f)| *f)
        .ok_or_else(|| {
            let known: Vec<&str> = spec.units.iter().map(|(u, _)| *u).collect();
            problem(
                file,
                format!("column `{}`", spec.name),
                format!(
                    "unit `[{unit}]` unknown; expected one of [{}]",
                    known.join("], [")
                ),
            )
        })?;
    Ok(Some((i, factor)))
}

/// Reads a recording.
///
/// # Errors
/// [`TaskError::Read`] if the file cannot be read; [`TaskError::Recording`] naming the
/// column (missing, unknown unit) or the line (a cell that is not a number, a short row).
pub fn read_recording(file: &Path) -> Result<RecordedRun, TaskError> {
    let bytes = std::fs::read(file).map_err(|source| TaskError::Read {
        file: file.to_path_buf(),
        source,
    })?;
    let mut reader = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .trim(csv::Trim::All)
        .flexible(true)
        .from_reader(bytes.as_slice());
    let header: Vec<Option<(String, String)>> = reader
        .headers()
        .map_err(|e| problem(file, "header", e.to_string()))?
        .iter()
        .map(split_header)
        .collect();
    let required = |spec: &ColumnSpec| {
        find_column(file, &header, spec)?.ok_or_else(|| {
            problem(
                file,
                format!("column `{}`", spec.name),
                format!(
                    "missing: the header must name it with its unit, e.g. `{} [{}]`",
                    spec.name, spec.units[0].0
                ),
            )
        })
    };
    let time = required(&TIME)?;
    let speed = required(&SPEED)?;
    let steering = required(&STEERING)?;
    let mut signal_columns = Vec::new();
    for s in DecaySignal::ALL {
        if let Some(c) = find_column(file, &header, &signal_column(s))? {
            signal_columns.push((s, c));
        }
    }
    if signal_columns.is_empty() {
        return Err(problem(
            file,
            "columns",
            "none of `hitch_angle [deg]`, `trailer_yaw_rate [deg/s]` or `car_yaw_rate [deg/s]`: the test needs one of them",
        ));
    }
    let mut run = RecordedRun {
        file: file.to_path_buf(),
        time_s: Vec::new(),
        speed_mps: Vec::new(),
        steering_rad: Vec::new(),
        signals: signal_columns
            .iter()
            .map(|(s, _)| (*s, Vec::new()))
            .collect(),
        lines: Vec::new(),
    };
    for record in reader.records() {
        let record = record.map_err(|e| problem(file, "data", e.to_string()))?;
        let line = record.position().map_or(0, |p| p.line());
        let cell = |(i, factor): (usize, f64), name: &str| -> Result<f64, TaskError> {
            let text = record.get(i).ok_or_else(|| {
                problem(
                    file,
                    format!("line {line}"),
                    format!("no value for `{name}`"),
                )
            })?;
            text.parse::<f64>().map(|v| v * factor).map_err(|_| {
                problem(
                    file,
                    format!("line {line}, column `{name}`"),
                    format!("`{text}` is not a number"),
                )
            })
        };
        run.time_s.push(cell(time, "time")?);
        run.speed_mps.push(cell(speed, "speed")?);
        run.steering_rad.push(cell(steering, "steering_angle")?);
        for ((s, c), (_, values)) in signal_columns.iter().zip(run.signals.iter_mut()) {
            values.push(cell(*c, s.as_str())?);
        }
        run.lines.push(line);
    }
    Ok(run)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(name: &str, text: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("sway-recording-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn columns_are_found_by_name_and_converted_to_si() {
        // reference: 36 km/h = 10 m/s, 180° = π rad, 90 deg/s = π/2 rad/s
        let p = write(
            "ok.csv",
            "# logger v2\nTime [s], extra [V], speed [km/h], steering_angle [deg], car_yaw_rate [deg/s]\n0,5,36,180,90\n0.02,5,36,0,0\n",
        );
        let r = read_recording(&p).unwrap();
        assert_eq!(r.time_s, vec![0.0, 0.02]);
        assert!((r.speed_mps[0] - 10.0).abs() < 1e-12);
        assert!((r.steering_rad[0] - std::f64::consts::PI).abs() < 1e-12);
        let (s, v) = r.signal(DecaySignal::HitchAngle);
        assert_eq!(s, DecaySignal::CarYawRate);
        assert!((v[0] - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert_eq!(r.lines, vec![3, 4]);
    }

    #[test]
    fn bad_files_name_the_column_or_the_line() {
        let missing = write(
            "missing.csv",
            "time [s],speed [m/s],hitch_angle [deg]\n0,1,2\n",
        );
        let e = read_recording(&missing).unwrap_err().to_string();
        assert!(
            e.contains("missing.csv") && e.contains("`steering_angle`"),
            "{e}"
        );
        let unit = write(
            "unit.csv",
            "time [s],speed [mph],steering_angle [deg],hitch_angle [deg]\n0,1,2,3\n",
        );
        let e = read_recording(&unit).unwrap_err().to_string();
        assert!(e.contains("column `speed`") && e.contains("[mph]"), "{e}");
        let cell = write(
            "cell.csv",
            "time [s],speed [m/s],steering_angle [deg],hitch_angle [deg]\n0,1,2,3\n0.02,1,x2,3\n",
        );
        let e = read_recording(&cell).unwrap_err().to_string();
        assert!(
            e.contains("line 3, column `steering_angle`") && e.contains("`x2`"),
            "{e}"
        );
        let none = write(
            "none.csv",
            "time [s],speed [m/s],steering_angle [deg]\n0,1,2\n",
        );
        let e = read_recording(&none).unwrap_err().to_string();
        assert!(e.contains("hitch_angle"), "{e}");
    }
}
