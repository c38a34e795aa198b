//! The band-pass against its design: the prewarped bilinear transform puts its −3 dB points
//! exactly on the band's edges and its unit peak between them; zero gain at 0 Hz; no
//! transient from a constant input once primed.

use sway_detect::filter::{BandPass, SwayBand};

#[test]
fn the_band_edges_are_the_minus_3_db_points_and_the_peak_gain_is_one() {
    for (band, rate) in [
        (SwayBand::default(), 100.0),
        (
            SwayBand {
                low_hz: 0.3,
                high_hz: 2.0,
            },
            50.0,
        ),
    ] {
        let f = BandPass::new(band, rate).unwrap();
        // reference: |H| = 1/√2 at the edges (prewarped), to rounding
        for edge in [band.low_hz, band.high_hz] {
            let g = f.gain(edge, rate);
            assert!(
                (g - 0.5_f64.sqrt()).abs() < 1e-12,
                "{band:?}: |H({edge})| = {g}"
            );
        }
        // the peak: at the digital image of the analog centre, f = rate/π · atan(√(tan·tan))
        let warp = |f: f64| (std::f64::consts::PI * f / rate).tan();
        let centre =
            rate / std::f64::consts::PI * (warp(band.low_hz) * warp(band.high_hz)).sqrt().atan();
        assert!((f.gain(centre, rate) - 1.0).abs() < 1e-12);
        assert!(f.gain(1e-9, rate) < 1e-8);
    }
    // slow cornering at 0.1 Hz passes the default band at 18 % (the counter's tests use it)
    let f = BandPass::new(SwayBand::default(), 100.0).unwrap();
    assert!(
        (f.gain(0.1, 100.0) - 0.18).abs() < 0.01,
        "{}",
        f.gain(0.1, 100.0)
    );
}

#[test]
fn a_primed_filter_passes_nothing_of_a_constant_input() {
    let mut f = BandPass::new(SwayBand::default(), 100.0).unwrap();
    f.prime(0.37);
    for _ in 0..1000 {
        assert!(f.filter(0.37).abs() < 1e-15);
    }
    // and a unit step from rest rings up and back to zero (zero gain at 0 Hz)
    let mut g = BandPass::new(SwayBand::default(), 100.0).unwrap();
    let ys: Vec<f64> = (0..3000).map(|_| g.filter(1.0)).collect();
    assert!(ys.iter().cloned().fold(0.0, f64::max) > 0.1);
    assert!(ys.last().unwrap().abs() < 1e-9);
}
