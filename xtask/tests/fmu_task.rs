//! `cargo xtask fmu`: both archives written, each with its model description, the shared
//! library where its FMI version puts it, and the documentation; the summary's counts are
//! the model description's.

use std::io::Read;

mod common;

/// The entry names of a zip archive, and the text of `modelDescription.xml`.
fn entries(file: &std::path::Path) -> (Vec<String>, String) {
    let mut zip = zip::ZipArchive::new(std::fs::File::open(file).unwrap()).unwrap();
    let names: Vec<String> = zip
        .file_names()
        .map(|n| n.expect("an entry name").into_owned())
        .collect();
    let mut xml = String::new();
    zip.by_name("modelDescription.xml")
        .unwrap()
        .read_to_string(&mut xml)
        .unwrap();
    (names, xml)
}

#[test]
fn the_fmu_task_writes_both_archives() {
    let dir = tempfile::tempdir().unwrap();
    let results = dir.path().join("results");
    common::run_ok(&["fmu", "--results", results.to_str().unwrap()]);
    let out = results.join("fmu");
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    for (file, version, library) in [
        (
            "trailer_sway.fmu",
            "2.0",
            "binaries/linux64/trailer_sway.so",
        ),
        (
            "trailer_sway_fmi3.fmu",
            "3.0",
            "binaries/x86_64-linux/trailer_sway.so",
        ),
    ] {
        let (names, xml) = entries(&out.join(file));
        assert!(names.iter().any(|n| n == library), "{file}: {names:?}");
        assert!(
            names.iter().any(|n| n.starts_with("documentation/")),
            "{file}: {names:?}"
        );
        assert!(xml.contains(&format!("fmiVersion=\"{version}\"")), "{file}");
        for name in [
            "steering_angle_rad",
            "speed_mps",
            "yaw_moment_nm",
            "trailer_lateral_force_n",
            "hitch_angle_rad",
            "loss_of_control",
            "initial_hitch_angle_rad",
            "trailer.mass",
            "controller.delay_s",
        ] {
            assert!(xml.contains(&format!("name=\"{name}\"")), "{file}: {name}");
        }
        // one ScalarVariable (FMI 2.0) or typed variable (3.0) per variable of the summary
        let total = summary["variables"]["total"].as_u64().unwrap() as usize;
        let variables = xml
            .split_once("<ModelVariables>")
            .and_then(|(_, rest)| rest.split_once("</ModelVariables>"))
            .map_or("", |(inside, _)| inside);
        let declared = variables.matches(" valueReference=").count();
        assert_eq!(declared, total, "{file}");
    }
}
