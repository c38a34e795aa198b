//! fig4b's computation: the open-loop pair against the committed results.

use sway::bifurcation::{CycleExtent, DiagramSettings, LoopLaw};
use sway_studies::fig4b::closed_loop_diagram;
use trailer_model::{Model, VehicleParams};

fn model() -> Model {
    Model::new(VehicleParams::default()).unwrap()
}

/// A number of a committed `results/<task>/summary.json` at the key `path`.
fn committed(task: &str, path: &[&str]) -> f64 {
    let file = format!(
        "{}/../../results/{task}/summary.json",
        env!("CARGO_MANIFEST_DIR")
    );
    let text = std::fs::read_to_string(&file).expect("committed summary");
    let mut v: serde_json::Value = serde_json::from_str(&text).expect("json");
    for k in path {
        v = match (v.is_array(), k.parse::<usize>()) {
            (true, Ok(i)) => v[i].take(),
            _ => v[*k].take(),
        };
    }
    v.as_f64()
        .unwrap_or_else(|| panic!("{file}: {path:?} is not a number"))
}

#[test]
fn derived_range_reproduces_table_i_fig4b_open_loop_pair() {
    // reference: results/fig4b/summary.json of main, pair 0 (open loop, L = 40, corrected
    // on the defining systems): Hopf and fold to 1e-9 relative
    let m = model();
    let p = closed_loop_diagram(
        &m,
        LoopLaw::OPEN_LOOP,
        &DiagramSettings::closed_loop(),
        &sway::ranging::SpeedLimits::default(),
        CycleExtent::WholeRange,
    )
    .unwrap();
    let s = p.summary(LoopLaw::OPEN_LOOP);
    let hopf = committed("fig4b", &["pairs", "0", "hopf_v_mps"]);
    let fold = committed("fig4b", &["pairs", "0", "fold_v_mps"]);
    assert!((s.hopf_v_mps.unwrap() - hopf).abs() <= 1e-9 * hopf, "{s:?}");
    assert!((s.fold_v_mps.unwrap() - fold).abs() <= 1e-9 * fold, "{s:?}");
    assert!(s.reason.is_none());
}
