//! The FMI 2.0 Co-Simulation entry points (`fmi2Functions.h`): every function of the
//! standard's common and co-simulation sets; model-exchange and directional derivatives
//! are refused with `fmi2Error`.

#![allow(non_snake_case, clippy::missing_safety_doc)]

use std::ffi::{CString, c_char, c_void};

use super::{Component, Fmi2Logger, Logger, Status, call, slice, slice_mut, text};
use crate::FmuError;
use crate::instance::Snapshot;
use crate::variables::{Kind, Value};

/// fmi2CallbackFunctions
#[repr(C)]
#[derive(Debug)]
pub struct Fmi2CallbackFunctions {
    /// logger
    pub logger: Option<Fmi2Logger>,
    /// allocateMemory (unused: Rust allocates)
    pub allocate_memory: Option<unsafe extern "C" fn(usize, usize) -> *mut c_void>,
    /// freeMemory (unused)
    pub free_memory: Option<unsafe extern "C" fn(*mut c_void)>,
    /// stepFinished (unused: doStep is synchronous)
    pub step_finished: Option<unsafe extern "C" fn(*mut c_void, i32)>,
    /// componentEnvironment
    pub component_environment: *mut c_void,
}

type C = *mut Component;

#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetTypesPlatform() -> *const c_char {
    c"default".as_ptr()
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetVersion() -> *const c_char {
    c"2.0".as_ptr()
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetDebugLogging(
    c: C,
    logging_on: i32,
    _n: usize,
    _categories: *const *const c_char,
) -> Status {
    unsafe {
        call(c, "fmi2SetDebugLogging", |c| {
            c.logging = logging_on != 0;
            Ok(Status::Ok)
        })
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2Instantiate(
    name: *const c_char,
    fmu_type: i32,
    _guid: *const c_char,
    resource_location: *const c_char,
    functions: *const Fmi2CallbackFunctions,
    _visible: i32,
    logging_on: i32,
) -> C {
    let (logger, env) = if functions.is_null() {
        (None, std::ptr::null_mut())
    } else {
        // SAFETY: the importer's struct
        let f = unsafe { &*functions };
        (f.logger, f.component_environment)
    };
    let logger = Logger::V2(logger, env);
    // SAFETY: C strings of the importer
    let (name, location) = unsafe { (text(name), text(resource_location)) };
    if fmu_type != 1 {
        let c = super::instantiate(name, &location, logger, true);
        if !c.is_null() {
            // SAFETY: just made
            unsafe {
                (*c).log(
                    Status::Error,
                    "logStatusError",
                    "this FMU is for co-simulation only (fmi2CoSimulation)",
                );
                super::free(c);
            }
        }
        return std::ptr::null_mut();
    }
    super::instantiate(name, &location, logger, logging_on != 0)
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2FreeInstance(c: C) {
    unsafe { super::free(c) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetupExperiment(
    c: C,
    _tolerance_defined: i32,
    _tolerance: f64,
    start_time: f64,
    _stop_time_defined: i32,
    _stop_time: f64,
) -> Status {
    unsafe {
        call(c, "fmi2SetupExperiment", |c| {
            c.instance.set_start_time(start_time)?;
            c.last_successful_s = start_time;
            Ok(Status::Ok)
        })
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2EnterInitializationMode(c: C) -> Status {
    unsafe {
        call(c, "fmi2EnterInitializationMode", |c| {
            c.instance.enter_initialization()?;
            Ok(Status::Ok)
        })
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2ExitInitializationMode(c: C) -> Status {
    unsafe {
        call(c, "fmi2ExitInitializationMode", |c| {
            c.instance.exit_initialization()?;
            Ok(Status::Ok)
        })
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2Terminate(c: C) -> Status {
    unsafe {
        call(c, "fmi2Terminate", |c| {
            c.instance.terminate();
            Ok(Status::Ok)
        })
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2Reset(c: C) -> Status {
    unsafe {
        call(c, "fmi2Reset", |c| {
            c.reset();
            Ok(Status::Ok)
        })
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetReal(c: C, vr: *const u32, n: usize, value: *mut f64) -> Status {
    unsafe {
        call(c, "fmi2GetReal", |c| {
            super::get_reals(c, slice(vr, n)?, slice_mut(value, n)?)
        })
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetInteger(c: C, vr: *const u32, n: usize, value: *mut i32) -> Status {
    unsafe {
        call(c, "fmi2GetInteger", |c| {
            let (vr, out) = (slice(vr, n)?, slice_mut(value, n)?);
            for (r, o) in vr.iter().zip(out.iter_mut()) {
                if let Value::Integer(x) = c.instance.get(*r, Kind::Integer)? {
                    *o = x;
                }
            }
            Ok(Status::Ok)
        })
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetBoolean(c: C, vr: *const u32, n: usize, value: *mut i32) -> Status {
    unsafe {
        call(c, "fmi2GetBoolean", |c| {
            let (vr, out) = (slice(vr, n)?, slice_mut(value, n)?);
            for (r, o) in vr.iter().zip(out.iter_mut()) {
                if let Value::Boolean(x) = c.instance.get(*r, Kind::Boolean)? {
                    *o = i32::from(x);
                }
            }
            Ok(Status::Ok)
        })
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetString(
    c: C,
    vr: *const u32,
    n: usize,
    value: *mut *const c_char,
) -> Status {
    unsafe {
        call(c, "fmi2GetString", |c| {
            let (vr, out) = (slice(vr, n)?, slice_mut(value, n)?);
            c.strings.clear();
            for r in vr {
                if let Value::String(s) = c.instance.get(*r, Kind::String)? {
                    c.strings.push(CString::new(s).unwrap_or_default());
                }
            }
            for (o, s) in out.iter_mut().zip(&c.strings) {
                *o = s.as_ptr();
            }
            Ok(Status::Ok)
        })
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetReal(c: C, vr: *const u32, n: usize, value: *const f64) -> Status {
    unsafe {
        call(c, "fmi2SetReal", |c| {
            super::set_reals(c, slice(vr, n)?, slice(value, n)?)
        })
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetInteger(
    c: C,
    vr: *const u32,
    n: usize,
    value: *const i32,
) -> Status {
    unsafe {
        call(c, "fmi2SetInteger", |c| {
            for (r, x) in slice(vr, n)?.iter().zip(slice(value, n)?) {
                c.instance.set(*r, Value::Integer(*x))?;
            }
            Ok(Status::Ok)
        })
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetBoolean(
    c: C,
    vr: *const u32,
    n: usize,
    value: *const i32,
) -> Status {
    unsafe {
        call(c, "fmi2SetBoolean", |c| {
            for (r, x) in slice(vr, n)?.iter().zip(slice(value, n)?) {
                c.instance.set(*r, Value::Boolean(*x != 0))?;
            }
            Ok(Status::Ok)
        })
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetString(
    c: C,
    vr: *const u32,
    n: usize,
    value: *const *const c_char,
) -> Status {
    unsafe {
        call(c, "fmi2SetString", |c| {
            for (r, s) in slice(vr, n)?.iter().zip(slice(value, n)?) {
                c.instance.set(*r, Value::String(text(*s)))?;
            }
            Ok(Status::Ok)
        })
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetFMUstate(c: C, state: *mut *mut c_void) -> Status {
    unsafe {
        call(c, "fmi2GetFMUstate", |c| {
            if state.is_null() {
                return Err(FmuError::State("a null FMUstate pointer".into()));
            }
            let snapshot = c.instance.snapshot()?;
            let old = *state as *mut Snapshot;
            if old.is_null() {
                *state = Box::into_raw(Box::new(snapshot)) as *mut c_void;
            } else {
                *old = snapshot;
            }
            Ok(Status::Ok)
        })
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetFMUstate(c: C, state: *mut c_void) -> Status {
    unsafe {
        call(c, "fmi2SetFMUstate", |c| {
            let s = state as *const Snapshot;
            if s.is_null() {
                return Err(FmuError::State("a null FMUstate".into()));
            }
            c.instance.restore(&*s)?;
            c.terminated = false;
            c.last_successful_s = c.instance.time();
            Ok(Status::Ok)
        })
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2FreeFMUstate(c: C, state: *mut *mut c_void) -> Status {
    unsafe {
        call(c, "fmi2FreeFMUstate", |_| {
            if !state.is_null() && !(*state).is_null() {
                drop(Box::from_raw(*state as *mut Snapshot));
                *state = std::ptr::null_mut();
            }
            Ok(Status::Ok)
        })
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SerializedFMUstateSize(
    c: C,
    state: *mut c_void,
    size: *mut usize,
) -> Status {
    unsafe {
        call(c, "fmi2SerializedFMUstateSize", |_| {
            let s = state as *const Snapshot;
            if s.is_null() || size.is_null() {
                return Err(FmuError::State("a null FMUstate or size".into()));
            }
            *size = (*s).to_bytes()?.len();
            Ok(Status::Ok)
        })
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SerializeFMUstate(
    c: C,
    state: *mut c_void,
    bytes: *mut u8,
    size: usize,
) -> Status {
    unsafe {
        call(c, "fmi2SerializeFMUstate", |_| {
            let s = state as *const Snapshot;
            if s.is_null() {
                return Err(FmuError::State("a null FMUstate".into()));
            }
            let data = (*s).to_bytes()?;
            if data.len() != size {
                return Err(FmuError::State(format!(
                    "a buffer of {size} bytes for a state of {}",
                    data.len()
                )));
            }
            slice_mut(bytes, size)?.copy_from_slice(&data);
            Ok(Status::Ok)
        })
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2DeSerializeFMUstate(
    c: C,
    bytes: *const u8,
    size: usize,
    state: *mut *mut c_void,
) -> Status {
    unsafe {
        call(c, "fmi2DeSerializeFMUstate", |_| {
            if state.is_null() {
                return Err(FmuError::State("a null FMUstate pointer".into()));
            }
            let snapshot = Snapshot::from_bytes(slice(bytes, size)?)?;
            let old = *state as *mut Snapshot;
            if old.is_null() {
                *state = Box::into_raw(Box::new(snapshot)) as *mut c_void;
            } else {
                *old = snapshot;
            }
            Ok(Status::Ok)
        })
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2DoStep(c: C, t: f64, h: f64, _no_set_prior: i32) -> Status {
    unsafe { call(c, "fmi2DoStep", |c| super::do_step(c, t, h)) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2CancelStep(c: C) -> Status {
    unsafe { call(c, "fmi2CancelStep", |_| Ok(Status::Ok)) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetStatus(c: C, _kind: i32, value: *mut i32) -> Status {
    unsafe {
        call(c, "fmi2GetStatus", |c| {
            if !value.is_null() {
                *value = if c.terminated {
                    Status::Discard
                } else {
                    Status::Ok
                } as i32;
            }
            Ok(Status::Ok)
        })
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetRealStatus(c: C, kind: i32, value: *mut f64) -> Status {
    unsafe {
        call(c, "fmi2GetRealStatus", |c| {
            if kind != 2 || value.is_null() {
                return Err(FmuError::State(
                    "only fmi2LastSuccessfulTime is a real status".into(),
                ));
            }
            *value = c.last_successful_s;
            Ok(Status::Ok)
        })
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetIntegerStatus(c: C, _kind: i32, _value: *mut i32) -> Status {
    unsafe { call(c, "fmi2GetIntegerStatus", |_| Ok(Status::Discard)) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetBooleanStatus(c: C, kind: i32, value: *mut i32) -> Status {
    unsafe {
        call(c, "fmi2GetBooleanStatus", |c| {
            if kind != 3 || value.is_null() {
                return Err(FmuError::State(
                    "only fmi2Terminated is a boolean status".into(),
                ));
            }
            *value = i32::from(c.terminated);
            Ok(Status::Ok)
        })
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetStringStatus(
    c: C,
    _kind: i32,
    _value: *mut *const c_char,
) -> Status {
    unsafe { call(c, "fmi2GetStringStatus", |_| Ok(Status::Discard)) }
}

/// Functions the FMU does not provide (its description says so): logged, `fmi2Error`. They
/// read only the instance, the first argument (the C calling convention leaves the others
/// to the caller).
macro_rules! refused {
    ($($name:ident),* $(,)?) => {$(
        #[unsafe(no_mangle)]
        pub unsafe extern "C" fn $name(c: C) -> Status {
            unsafe {
                call(c, stringify!($name), |_| {
                    Err($crate::FmuError::Phase {
                        call: stringify!($name),
                        phase: "in this FMU (not provided: see modelDescription.xml)",
                    })
                })
            }
        }
    )*};
}
pub(crate) use refused;

refused! {
    fmi2GetDirectionalDerivative,
    fmi2SetRealInputDerivatives,
    fmi2GetRealOutputDerivatives,
}
