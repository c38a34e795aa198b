use rayon::prelude::*;
use sway::bifurcation::corners::{CornerOptions, run_at};
use trailer_model::{Model, VehicleParams};
fn main() {
    let model = Model::new(VehicleParams::default()).unwrap();
    let args: Vec<f64> = std::env::args()
        .skip(1)
        .map(|a| a.parse().unwrap())
        .collect();
    let (tau, kick) = (args[0], args[1]);
    let (v0, v1, nv, d0, d1, nd) = (
        args[2],
        args[3],
        args[4] as usize,
        args[5],
        args[6],
        args[7] as usize,
    );
    let o = CornerOptions::default();
    let mut pts = Vec::new();
    for i in 0..nv {
        for j in 0..nd {
            let v = if nv > 1 {
                v0 + (v1 - v0) * i as f64 / (nv - 1) as f64
            } else {
                v0
            };
            let d = if nd > 1 {
                d0 + (d1 - d0) * j as f64 / (nd - 1) as f64
            } else {
                d0
            };
            pts.push((v, d));
        }
    }
    let res: Vec<_> = pts
        .par_iter()
        .map(|&(v, d)| (v, d, run_at(&model, tau, v, d, kick, &o)))
        .collect();
    for (v, d, r) in res {
        match r {
            Ok(r) => {
                let e = &r.evidence;
                println!(
                    "V={v:.2} D={d:.4} {:?} amp={:.3}->{:.3} deg peaks={:?} base={:?} clusters={} rho={:?} loc={:?}",
                    e.class,
                    e.amplitude_first_half.to_degrees(),
                    e.amplitude_second_half.to_degrees(),
                    e.peaks
                        .iter()
                        .take(4)
                        .map(|p| (p.omega_rad_s * 1000.0).round() / 1000.0)
                        .collect::<Vec<_>>(),
                    e.base_frequencies_rad_s,
                    e.section_clusters,
                    e.section_rotation_number,
                    r.loss_of_control_time_s
                );
            }
            Err(e) => println!("V={v:.2} D={d:.4} error {e}"),
        }
    }
}
