//! `cargo xtask lateral_stability --recording FILE …`: recorded pulse-steer runs analysed
//! from the command line, bad recordings reported by file and line while the others are
//! analysed.
//!
//! Reference: synthetic recordings whose sway after the impulse is exactly
//! e^{σt}·sin(ωt) with damping ratio D = −σ/√(σ² + ω²) chosen per run (0.15, 0.10, 0.05 at
//! 72, 90, 108 km/h): the straight line through D(V) reaches zero at 35 m/s exactly; the
//! peaks (a 50 Hz recording, zero-phase low-pass, parabolic refinement) give each D to
//! 1e-3, so the test's critical speed within 0.2 m/s.

use std::fmt::Write as _;
use std::path::Path;

mod common;

/// A recording at `speed_kmh` whose sway decays with damping ratio `d`; `nan_row` puts
/// `nan` into the hitch angle of that data row (counted from 0).
fn recording(speed_kmh: f64, d: f64, nan_row: Option<usize>) -> String {
    let omega = std::f64::consts::TAU * 0.6;
    let sigma = -d * omega / (1.0 - d * d).sqrt();
    let (start, duration) = (1.0, 0.4);
    let mut text =
        String::from("# synthetic\ntime [s],speed [km/h],steering_angle [deg],hitch_angle [deg]\n");
    for k in 0..1500 {
        let t = k as f64 * 0.02;
        let steering = if t > start && t < start + duration {
            2.0 * (std::f64::consts::PI * (t - start) / duration).sin()
        } else {
            0.0
        };
        let s = t - start - duration;
        let theta = if s > 0.0 {
            2.0 * (sigma * s).exp() * (omega * s).sin()
        } else {
            0.0
        };
        let theta = if nan_row == Some(k) {
            "nan".to_string()
        } else {
            format!("{theta}")
        };
        writeln!(text, "{t},{speed_kmh},{steering},{theta}").unwrap();
    }
    text
}

fn write(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.display().to_string()
}

#[test]
fn recordings_give_the_test_critical_speed_and_bad_ones_are_named() {
    let dir = std::env::temp_dir().join(format!("sway-recordings-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let good: Vec<String> = [(72.0, 0.15), (90.0, 0.10), (108.0, 0.05)]
        .iter()
        .enumerate()
        .map(|(i, &(v, d))| write(&dir, &format!("run{i}.csv"), &recording(v, d, None)))
        .collect();
    // data row 5 is line 8 of the file (a comment, the header, rows from 0)
    let nan = write(&dir, "nan.csv", &recording(80.0, 0.1, Some(5)));
    let missing = write(
        &dir,
        "missing.csv",
        &recording(80.0, 0.1, None).replace("steering_angle [deg]", "wheel [deg]"),
    );
    let results = dir.join("results");
    let mut args = vec!["lateral_stability", "--results", results.to_str().unwrap()];
    for f in good.iter().chain([&nan, &missing]) {
        args.extend(["--recording", f.as_str()]);
    }
    let out = common::run_ok(&args);
    let stdout = String::from_utf8_lossy(&out.stdout);
    println!("{stdout}");
    assert!(stdout.contains("3 of 5 recording(s) analysed"), "{stdout}");
    assert!(
        stdout.contains("nan.csv: line 8, column `hitch_angle`"),
        "{stdout}"
    );
    assert!(
        stdout.contains("missing.csv: column `steering_angle`"),
        "{stdout}"
    );
    let summary: serde_json::Value = serde_json::from_slice(
        &std::fs::read(results.join("lateral_stability_recordings/summary.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(summary["analysed"], 3);
    assert_eq!(summary["failed"], 2);
    let rows = summary["recordings"].as_array().unwrap();
    for (row, (v, d)) in rows.iter().zip([(20.0, 0.15), (25.0, 0.10), (30.0, 0.05)]) {
        let (speed, damping) = (
            row["speed_mps"].as_f64().unwrap(),
            row["damping_ratio"].as_f64().unwrap(),
        );
        assert!((speed - v).abs() < 1e-9, "{row}");
        assert!((damping - d).abs() < 1e-3, "{row}");
    }
    let vt = summary["test_critical_speed_mps"].as_f64().unwrap();
    assert!((vt - 35.0).abs() < 0.2, "test critical speed {vt}");
    assert!(
        results
            .join("lateral_stability_recordings/recordings.png")
            .exists()
    );
    assert!(
        results
            .join("lateral_stability_recordings/recordings.csv")
            .exists()
    );

    // nothing readable: an error naming every file, and nothing written
    let empty = dir.join("empty-results");
    let out = common::run(&[
        "lateral_stability",
        "--results",
        empty.to_str().unwrap(),
        "--recording",
        &nan,
        "--recording",
        &missing,
    ]);
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("nan.csv") && stderr.contains("missing.csv"),
        "{stderr}"
    );
    assert!(!empty.join("lateral_stability_recordings").exists());
    // --recording belongs to lateral_stability
    let out = common::run(&["linear", "--recording", &nan]);
    assert!(!out.status.success());
    let _ = std::fs::remove_dir_all(&dir);
}
