use std::path::Path;
use sway_tasks::limits::*;

#[test]
fn bounds_name_key_value_limit_and_cost() {
    let e = bound(Path::new("f.toml"), "speed.cells", 1e8, 1e5, || {
        "≈ 6 GB".into()
    })
    .expect_err("over the limit")
    .to_string();
    for part in ["f.toml", "speed.cells", "100000000", "100000", "6 GB"] {
        assert!(e.contains(part), "{e} lacks {part}");
    }
    assert!(bound(Path::new("f"), "k", f64::NAN, 1.0, String::new).is_err());
    let e = check_series(Path::new("f"), "", 40.0, 1e-9, 1)
        .expect_err("4e10 samples")
        .to_string();
    assert!(e.contains("output_step_s"), "{e}");
    assert_eq!(
        check_series(Path::new("f"), "", 40.0, 0.02, 4).ok(),
        Some(8000.0)
    );
}
