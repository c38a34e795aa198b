//! The DOP853 coefficients against the order conditions they must satisfy (Butcher's
//! conditions, Hairer–Nørsett–Wanner, *Solving ODEs I*, §II.2): a transcription error in
//! any coefficient breaks at least one of them. Tolerance 1e-13: the coefficients are
//! given to 30 digits and rounded to f64; the sums have terms up to 43 in magnitude.

use super::*;

const TOL: f64 = 1e-13;

/// The 16 × 16 Runge–Kutta matrix (stage 13 is the FSAL stage with row b) and the nodes.
fn tableau() -> ([[f64; 16]; 16], [f64; 16]) {
    let mut a = [[0.0; 16]; 16];
    let rows: [&[(usize, f64)]; 16] = [
        &[],
        &[(1, A21)],
        &[(1, A31), (2, A32)],
        &[(1, A41), (3, A43)],
        &[(1, A51), (3, A53), (4, A54)],
        &[(1, A61), (4, A64), (5, A65)],
        &[(1, A71), (4, A74), (5, A75), (6, A76)],
        &[(1, A81), (4, A84), (5, A85), (6, A86), (7, A87)],
        &[(1, A91), (4, A94), (5, A95), (6, A96), (7, A97), (8, A98)],
        &[
            (1, A101),
            (4, A104),
            (5, A105),
            (6, A106),
            (7, A107),
            (8, A108),
            (9, A109),
        ],
        &[
            (1, A111),
            (4, A114),
            (5, A115),
            (6, A116),
            (7, A117),
            (8, A118),
            (9, A119),
            (10, A1110),
        ],
        &[
            (1, A121),
            (4, A124),
            (5, A125),
            (6, A126),
            (7, A127),
            (8, A128),
            (9, A129),
            (10, A1210),
            (11, A1211),
        ],
        &B_WEIGHTS,
        &[
            (1, A141),
            (7, A147),
            (8, A148),
            (9, A149),
            (10, A1410),
            (11, A1411),
            (12, A1412),
            (13, A1413),
        ],
        &[
            (1, A151),
            (6, A156),
            (7, A157),
            (8, A158),
            (11, A1511),
            (12, A1512),
            (13, A1513),
            (14, A1514),
        ],
        &[
            (1, A161),
            (6, A166),
            (7, A167),
            (8, A168),
            (9, A169),
            (13, A1613),
            (14, A1614),
            (15, A1615),
        ],
    ];
    for (i, row) in rows.iter().enumerate() {
        for &(j, v) in *row {
            a[i][j - 1] = v;
        }
    }
    let c = [
        0.0, C2, C3, C4, C5, C6, C7, C8, C9, C10, C11, 1.0, 1.0, C14, C15, C16,
    ];
    (a, c)
}

fn weights(pairs: &[(usize, f64)]) -> [f64; 16] {
    let mut b = [0.0; 16];
    for &(j, v) in pairs {
        b[j - 1] = v;
    }
    b
}

/// The 8th-order weights (stage, b), also row 13 of the matrix (FSAL).
const B_WEIGHTS: [(usize, f64); 8] = [
    (1, B1),
    (6, B6),
    (7, B7),
    (8, B8),
    (9, B9),
    (10, B10),
    (11, B11),
    (12, B12),
];

fn b8() -> [f64; 16] {
    weights(&B_WEIGHTS)
}

/// `Σᵢ wᵢ cᵢ^q`
fn moment(w: &[f64; 16], c: &[f64; 16], q: i32) -> f64 {
    w.iter().zip(c).map(|(w, c)| w * c.powi(q)).sum()
}

#[test]
fn every_row_sums_to_its_node() {
    let (a, c) = tableau();
    for i in 0..16 {
        let s: f64 = a[i].iter().sum();
        assert!(
            (s - c[i]).abs() < TOL,
            "row {}: Σa = {s}, c = {}",
            i + 1,
            c[i]
        );
    }
}

#[test]
fn the_weights_integrate_polynomials_to_degree_seven_and_bushy_trees_to_order_eight() {
    let (a, c) = tableau();
    let b = b8();
    // quadrature conditions Σ bᵢ cᵢ^{q−1} = 1/q, q = 1 … 8
    for q in 1..=8 {
        let m = moment(&b, &c, q - 1);
        assert!((m - 1.0 / q as f64).abs() < TOL, "q = {q}: {m}");
    }
    // Σ bᵢ aᵢⱼ cⱼ^{q} = 1/((q+1)(q+2)) for q + 2 ≤ 8, and Σ bᵢ cᵢ aᵢⱼ cⱼ^q = 1/((q+1)(q+3))
    for q in 0..=5 {
        let s: f64 = (0..16)
            .map(|i| b[i] * (0..16).map(|j| a[i][j] * c[j].powi(q)).sum::<f64>())
            .sum();
        let want = 1.0 / ((q + 1) * (q + 2)) as f64;
        assert!((s - want).abs() < TOL, "Σ b a c^{q}: {s} vs {want}");
        if q + 3 <= 8 {
            let s: f64 = (0..16)
                .map(|i| b[i] * c[i] * (0..16).map(|j| a[i][j] * c[j].powi(q)).sum::<f64>())
                .sum();
            let want = 1.0 / ((q + 1) * (q + 3)) as f64;
            assert!((s - want).abs() < TOL, "Σ b c a c^{q}: {s} vs {want}");
        }
    }
}

#[test]
fn the_error_estimators_have_orders_five_and_three() {
    let (_, c) = tableau();
    // the 8th-minus-5th order weights annihilate cᵏ for k ≤ 4 (both integrate them exactly)
    let er = weights(&[
        (1, ER1),
        (6, ER6),
        (7, ER7),
        (8, ER8),
        (9, ER9),
        (10, ER10),
        (11, ER11),
        (12, ER12),
    ]);
    for q in 0..=4 {
        let m = moment(&er, &c, q);
        assert!(m.abs() < TOL, "Σ er c^{q} = {m}");
    }
    // ...but not c⁵ (else the estimate would be of higher order)
    assert!(moment(&er, &c, 5).abs() > 1e-6);
    // the 3rd-order weights on stages 1, 9, 12
    let bhh = weights(&[(1, BHH1), (9, BHH2), (12, BHH3)]);
    for q in 1..=3 {
        let m = moment(&bhh, &c, q - 1);
        assert!((m - 1.0 / q as f64).abs() < TOL, "bhh, q = {q}: {m}");
    }
}

#[test]
fn the_dense_coefficients_vanish_at_both_ends_of_the_step() {
    // d-rows combine stage derivatives: each must be exact for constant f (Σ d = 0 keeps
    // the interpolant's value at θ = 0 and 1 = the step's ends, which the nested form
    // guarantees only if the higher terms carry no constant part)
    for (name, d) in [("d4", D4), ("d5", D5), ("d6", D6), ("d7", D7)] {
        let s: f64 = d.iter().sum();
        assert!(s.abs() < 1e-12, "{name}: Σ = {s}");
    }
}
