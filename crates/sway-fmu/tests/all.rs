//! The integration tests of this crate in one test binary (`autotests = false`).

#[path = "fmpy.rs"]
mod fmpy;
