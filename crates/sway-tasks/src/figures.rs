//! Figures drawn from library results: the panels of the stability charts (Fig. 4a), and
//! speeds a search's cap may have cut off ([`capped_speed_layers`]).

use stability::{Axis, Polyline, StabilityChart};
use sway::ranging::CappedSpeed;

use crate::plot::{Layer, Legend, Panel, Rgb, Shape, Stroke};

/// A speed curve over x whose speeds may be stable up to the search's cap: the line of the
/// speeds found (split where one is capped, labelled `label`) and the capped ones as
/// triangles at the cap in the same colour, so that no capped value is drawn as a measured
/// one ([`stable_up_to_key`] explains the triangles).
pub fn capped_speed_layers(
    points: &[(f64, CappedSpeed)],
    color: Rgb,
    stroke: Stroke,
    label: Option<&str>,
) -> Vec<Layer> {
    let line: Vec<(f64, f64)> = points
        .iter()
        .map(|&(x, v)| (x, v.found().unwrap_or(f64::NAN)))
        .collect();
    let capped: Vec<(f64, f64)> = points
        .iter()
        .filter_map(|&(x, v)| v.stable_up_to().map(|cap| (x, cap)))
        .collect();
    let mut layers = vec![Layer::line(line, color, stroke, label)];
    if !capped.is_empty() {
        layers.push(Layer::Markers {
            points: capped,
            color,
            shape: Shape::Triangle,
            size: 6,
            label: None,
        });
    }
    layers
}

/// The legend entry of [`capped_speed_layers`]' triangles: "stable up to `cap` m/s (the
/// speed cap)"; None when no point of `speeds` is capped.
pub fn stable_up_to_key(speeds: impl IntoIterator<Item = CappedSpeed>) -> Option<Layer> {
    let cap = speeds.into_iter().find_map(CappedSpeed::stable_up_to)?;
    Some(Layer::Markers {
        points: Vec::new(),
        color: Rgb(60, 60, 60),
        shape: Shape::Triangle,
        size: 6,
        label: Some(format!("stable up to {cap} m/s (the speed cap)")),
    })
}

/// Polylines as one line layer (NaN separators), clipped to `lo ≤ D ≤ hi` (pieces outside the
/// frame end at the frame edge instead of being drawn along it).
fn polylines_layer(
    lines: &[Polyline],
    (lo, hi): (f64, f64),
    color: Rgb,
    stroke: Stroke,
    label: Option<&str>,
) -> Layer {
    let mut pts: Vec<(f64, f64)> = Vec::new();
    let inside = |d: f64| d >= lo && d <= hi;
    let edge = |a: (f64, f64), b: (f64, f64)| {
        // point where segment a→b crosses the frame edge nearest to b's side
        let y = if a.1 > hi || b.1 > hi { hi } else { lo };
        let t = (y - a.1) / (b.1 - a.1);
        (a.0 + t * (b.0 - a.0), y)
    };
    for l in lines {
        let mut prev: Option<(f64, f64)> = None;
        pts.push((f64::NAN, f64::NAN));
        for p in &l.points {
            let cur = (p.v, p.d);
            match prev {
                None => {
                    if inside(cur.1) {
                        pts.push(cur);
                    }
                }
                Some(a) => match (inside(a.1), inside(cur.1)) {
                    (true, true) => pts.push(cur),
                    (true, false) => {
                        pts.push(edge(a, cur));
                        pts.push((f64::NAN, f64::NAN));
                    }
                    (false, true) => {
                        pts.push(edge(cur, a));
                        pts.push(cur);
                    }
                    (false, false) => {}
                },
            }
            prev = Some(cur);
        }
    }
    Layer::line(pts, color, stroke, label)
}

/// Stable/unstable shading as runs of equal state along each V column (few rectangles).
fn shading(chart: &StabilityChart, speed: &Axis, gain: &Axis) -> (Vec<[f64; 4]>, Vec<[f64; 4]>) {
    let (dv, dd) = (speed.step(), gain.step());
    let mut stable = Vec::new();
    let mut unstable = Vec::new();
    for (iv, &v) in chart.v.iter().enumerate() {
        let mut start = 0;
        for id in 1..=chart.d.len() {
            let s0 = chart.cell(iv, start).is_stable();
            if id == chart.d.len() || chart.cell(iv, id).is_stable() != s0 {
                let r = [
                    v - 0.5 * dv,
                    v + 0.5 * dv,
                    chart.d[start] - 0.5 * dd,
                    chart.d[id - 1] + 0.5 * dd,
                ];
                if s0 {
                    stable.push(r)
                } else {
                    unstable.push(r)
                }
                start = id;
            }
        }
    }
    (stable, unstable)
}

/// One panel of Fig. 4(a): green stable / red unstable shading, static boundary blue, dynamic
/// boundaries black, and (for τ > 0) the τ = 0 dynamic boundary dotted.
pub fn chart_panel(
    chart: &StabilityChart,
    reference: Option<&StabilityChart>,
    speed: &Axis,
    gain: &Axis,
) -> Panel {
    let (stable, unstable) = shading(chart, speed, gain);
    let mut p = Panel::new(&format!("τ = {} s", chart.tau), "V [m/s]", "D [s]")
        .x_range(speed.min, speed.max)
        .y_range(gain.min, gain.max)
        .legend(Legend::LowerLeft)
        .with(Layer::Rects {
            rects: stable,
            color: Rgb::GREEN,
            opacity: 0.35,
            label: Some("stable".into()),
        })
        .with(Layer::Rects {
            rects: unstable,
            color: Rgb::RED,
            opacity: 0.35,
            label: Some("unstable".into()),
        });
    if let Some(r) = reference.filter(|r| r.tau != chart.tau) {
        p = p.with(polylines_layer(
            &r.dynamic_boundaries,
            (gain.min, gain.max),
            Rgb::BLACK,
            Stroke::Dotted,
            Some("dynamic, τ = 0"),
        ));
    }
    p.with(polylines_layer(
        &chart.static_boundary,
        (gain.min, gain.max),
        Rgb::BLUE,
        Stroke::Solid,
        Some("static boundary"),
    ))
    .with(polylines_layer(
        &chart.dynamic_boundaries,
        (gain.min, gain.max),
        Rgb::BLACK,
        Stroke::Solid,
        Some("dynamic boundary"),
    ))
}
