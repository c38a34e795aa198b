//! The studies floor of trailer-sway: one module per task, each the whole computation of
//! the task — its typed config, the ranges it derives from the vehicle, the engines of
//! [`sway`] it calls and the values it returns. The task layer (`sway-tasks`) reads the
//! config, calls the study and writes what it returns; the Python package calls the same
//! studies.
//!
//! | module | task |
//! |---|---|
//! | [`fig3a`] | `fig3a`: the open loop's bifurcation diagram and time panels in the bistable range |
//! | [`fig3b`] | `fig3b`: braking out of sway with several ramp durations |
//! | [`fig4a`] | `fig4a`: linear stability charts in (V, D) per delay |
//! | [`fig4b`] | `fig4b`: bifurcation diagrams of the delayed closed loop |
//! | [`fig4c`] | `fig4c`: sway suppression by steering, braking and both |
//! | [`simulate`] | `simulate`: one user scenario; the time-series runs of `fig3a`, `fig3b`, `fig4c` |
//! | [`chart`] | `chart_nonlinear`: Hopf and fold-of-cycles curves, regions, codimension-two points |
//! | [`corners`] | `corners`: double-Hopf points, torus curves and the motion near them |
//! | [`gain_design`] | `gain_design`: the best gain D\*(τ) and the delay budget |
//! | [`control_design`] | `control_design`: every structure × actuator over the delays |
//! | [`mitigation`] | `mitigation`: the intervention that ends sway fastest from any phase |
//! | [`sweep`] | `sweep`, `brake_timing`, `study_*`: point-wise parallel studies |
//! | [`fleet`] | `variants`, fleets: the headline numbers of one vehicle |
//! | [`linear`] | `linear`: the open loop's V_crit, eigenvalues, sensitivities dV_crit/dp |
//! | [`loading`] | `loading`: V_crit over trailer mass × centre of gravity, tongue-load cut |
//! | [`variants`] | `variants`: the headline numbers of Table I with tyre relaxation and of vehicle files |
//! | [`roots`] | `roots`: the rightmost characteristic roots of a closed loop at one point |
//!
//! ```
//! use sway::charts::auto_range::SpeedBounds;
//! use sway_studies::fig4a::{Fig4aConfig, GainAxis, SpeedAxis, compute};
//! use trailer_model::{Model, VehicleParams};
//!
//! // Fig. 4(a) at τ = 0.2 s on a coarse grid, the ranges derived from Table I
//! let cfg = Fig4aConfig {
//!     speed: SpeedAxis { min_mps: None, max_mps: None, cells: 24 },
//!     gain: GainAxis { min_s: None, max_s: None, cells: 16 },
//!     delays_s: vec![0.2],
//!     summary: Default::default(),
//!     numerics: Default::default(),
//!     controller: None,
//! };
//! let model = Model::new(VehicleParams::default()).unwrap();
//! let fig = compute(&model, &cfg, &SpeedBounds::default()).unwrap();
//! // the delayed yaw-rate feedback raises the critical speed above the open loop's 34.75 m/s
//! let v = fig.summaries[0].v_crit_at_gain_mps.unwrap();
//! assert!(v > 35.0, "{v}");
//! ```

pub mod chart;
pub mod combination;
pub mod control_design;
pub mod corners;
pub mod fig3a;
pub mod fig3b;
pub mod fig4a;
pub mod fig4b;
pub mod fig4c;
pub mod fleet;
pub mod gain_design;
pub mod keyed;
pub mod lateral_stability;
pub mod linear;
pub mod loading;
pub mod mitigation;
pub mod modes;
pub mod roots;
pub mod simulate;
pub mod sway_assist;
pub mod sweep;
pub mod variants;
