//! The FMI 3.0 Co-Simulation entry points (`fmi3Functions.h`): every function of the
//! standard; model exchange and scheduled execution are not instantiated, and the
//! functions of features the description does not declare return `fmi3Error`.

#![allow(non_snake_case, clippy::missing_safety_doc)]

use std::ffi::{CString, c_char, c_void};

use super::fmi2::refused;
use super::{Component, Fmi3Logger, Logger, Status, call, slice, slice_mut, text};
use crate::variables::{Kind, Value};

type C = *mut Component;

#[unsafe(no_mangle)]
pub extern "C" fn fmi3GetVersion() -> *const c_char {
    c"3.0".as_ptr()
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi3SetDebugLogging(
    c: C,
    logging_on: bool,
    _n: usize,
    _categories: *const *const c_char,
) -> Status {
    unsafe {
        call(c, "fmi3SetDebugLogging", |c| {
            c.logging = logging_on;
            Ok(Status::Ok)
        })
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi3InstantiateCoSimulation(
    name: *const c_char,
    _token: *const c_char,
    resource_path: *const c_char,
    _visible: bool,
    logging_on: bool,
    _event_mode_used: bool,
    _early_return_allowed: bool,
    _required: *const u32,
    _n_required: usize,
    env: *mut c_void,
    log_message: Option<Fmi3Logger>,
    _intermediate_update: *const c_void,
) -> C {
    // SAFETY: C strings of the importer
    let (name, location) = unsafe { (text(name), text(resource_path)) };
    super::instantiate(name, &location, Logger::V3(log_message, env), logging_on)
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3InstantiateModelExchange() -> C {
    std::ptr::null_mut()
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi3InstantiateScheduledExecution() -> C {
    std::ptr::null_mut()
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi3FreeInstance(c: C) {
    unsafe { super::free(c) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi3EnterInitializationMode(
    c: C,
    _tolerance_defined: bool,
    _tolerance: f64,
    start_time: f64,
    _stop_time_defined: bool,
    _stop_time: f64,
) -> Status {
    unsafe {
        call(c, "fmi3EnterInitializationMode", |c| {
            c.instance.set_start_time(start_time)?;
            c.last_successful_s = start_time;
            c.instance.enter_initialization()?;
            Ok(Status::Ok)
        })
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi3ExitInitializationMode(c: C) -> Status {
    unsafe {
        call(c, "fmi3ExitInitializationMode", |c| {
            c.instance.exit_initialization()?;
            Ok(Status::Ok)
        })
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi3EnterStepMode(c: C) -> Status {
    unsafe { call(c, "fmi3EnterStepMode", |_| Ok(Status::Ok)) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi3Terminate(c: C) -> Status {
    unsafe {
        call(c, "fmi3Terminate", |c| {
            c.instance.terminate();
            Ok(Status::Ok)
        })
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi3Reset(c: C) -> Status {
    unsafe {
        call(c, "fmi3Reset", |c| {
            c.reset();
            Ok(Status::Ok)
        })
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi3GetFloat64(
    c: C,
    vr: *const u32,
    n: usize,
    values: *mut f64,
    _n_values: usize,
) -> Status {
    unsafe {
        call(c, "fmi3GetFloat64", |c| {
            super::get_reals(c, slice(vr, n)?, slice_mut(values, n)?)
        })
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi3SetFloat64(
    c: C,
    vr: *const u32,
    n: usize,
    values: *const f64,
    _n_values: usize,
) -> Status {
    unsafe {
        call(c, "fmi3SetFloat64", |c| {
            super::set_reals(c, slice(vr, n)?, slice(values, n)?)
        })
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi3GetInt32(
    c: C,
    vr: *const u32,
    n: usize,
    values: *mut i32,
    _n_values: usize,
) -> Status {
    unsafe {
        call(c, "fmi3GetInt32", |c| {
            for (r, o) in slice(vr, n)?.iter().zip(slice_mut(values, n)?.iter_mut()) {
                if let Value::Integer(x) = c.instance.get(*r, Kind::Integer)? {
                    *o = x;
                }
            }
            Ok(Status::Ok)
        })
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi3SetInt32(
    c: C,
    vr: *const u32,
    n: usize,
    values: *const i32,
    _n_values: usize,
) -> Status {
    unsafe {
        call(c, "fmi3SetInt32", |c| {
            for (r, x) in slice(vr, n)?.iter().zip(slice(values, n)?) {
                c.instance.set(*r, Value::Integer(*x))?;
            }
            Ok(Status::Ok)
        })
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi3GetBoolean(
    c: C,
    vr: *const u32,
    n: usize,
    values: *mut bool,
    _n_values: usize,
) -> Status {
    unsafe {
        call(c, "fmi3GetBoolean", |c| {
            for (r, o) in slice(vr, n)?.iter().zip(slice_mut(values, n)?.iter_mut()) {
                if let Value::Boolean(x) = c.instance.get(*r, Kind::Boolean)? {
                    *o = x;
                }
            }
            Ok(Status::Ok)
        })
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi3SetBoolean(
    c: C,
    vr: *const u32,
    n: usize,
    values: *const u8,
    _n_values: usize,
) -> Status {
    unsafe {
        call(c, "fmi3SetBoolean", |c| {
            for (r, x) in slice(vr, n)?.iter().zip(slice(values, n)?) {
                c.instance.set(*r, Value::Boolean(*x != 0))?;
            }
            Ok(Status::Ok)
        })
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi3GetString(
    c: C,
    vr: *const u32,
    n: usize,
    values: *mut *const c_char,
    _n_values: usize,
) -> Status {
    unsafe {
        call(c, "fmi3GetString", |c| {
            let (vr, out) = (slice(vr, n)?, slice_mut(values, n)?);
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
pub unsafe extern "C" fn fmi3SetString(
    c: C,
    vr: *const u32,
    n: usize,
    values: *const *const c_char,
    _n_values: usize,
) -> Status {
    unsafe {
        call(c, "fmi3SetString", |c| {
            for (r, s) in slice(vr, n)?.iter().zip(slice(values, n)?) {
                c.instance.set(*r, Value::String(text(*s)))?;
            }
            Ok(Status::Ok)
        })
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi3GetFMUState(c: C, state: *mut *mut c_void) -> Status {
    unsafe { super::fmi2::fmi2GetFMUstate(c, state) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi3SetFMUState(c: C, state: *mut c_void) -> Status {
    unsafe { super::fmi2::fmi2SetFMUstate(c, state) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi3FreeFMUState(c: C, state: *mut *mut c_void) -> Status {
    unsafe { super::fmi2::fmi2FreeFMUstate(c, state) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi3SerializedFMUStateSize(
    c: C,
    state: *mut c_void,
    size: *mut usize,
) -> Status {
    unsafe { super::fmi2::fmi2SerializedFMUstateSize(c, state, size) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi3SerializeFMUState(
    c: C,
    state: *mut c_void,
    bytes: *mut u8,
    size: usize,
) -> Status {
    unsafe { super::fmi2::fmi2SerializeFMUstate(c, state, bytes, size) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi3DeserializeFMUState(
    c: C,
    bytes: *const u8,
    size: usize,
    state: *mut *mut c_void,
) -> Status {
    unsafe { super::fmi2::fmi2DeSerializeFMUstate(c, bytes, size, state) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi3DoStep(
    c: C,
    t: f64,
    h: f64,
    _no_set_prior: bool,
    event_handling_needed: *mut bool,
    terminate_simulation: *mut bool,
    early_return: *mut bool,
    last_successful_time: *mut f64,
) -> Status {
    unsafe {
        call(c, "fmi3DoStep", |c| {
            let status = super::do_step(c, t, h)?;
            if !event_handling_needed.is_null() {
                *event_handling_needed = false;
            }
            if !terminate_simulation.is_null() {
                *terminate_simulation = c.terminated;
            }
            if !early_return.is_null() {
                *early_return = false;
            }
            if !last_successful_time.is_null() {
                *last_successful_time = c.last_successful_s;
            }
            // FMI 3.0 ends a simulation through terminateSimulation, not Discard
            Ok(if status == Status::Discard {
                Status::Ok
            } else {
                status
            })
        })
    }
}

refused! {
    fmi3EnterEventMode,
    fmi3GetFloat32, fmi3GetInt8, fmi3GetUInt8, fmi3GetInt16, fmi3GetUInt16, fmi3GetUInt32,
    fmi3GetInt64, fmi3GetUInt64, fmi3GetBinary, fmi3GetClock,
    fmi3SetFloat32, fmi3SetInt8, fmi3SetUInt8, fmi3SetInt16, fmi3SetUInt16, fmi3SetUInt32,
    fmi3SetInt64, fmi3SetUInt64, fmi3SetBinary, fmi3SetClock,
    fmi3GetNumberOfVariableDependencies, fmi3GetVariableDependencies,
    fmi3GetDirectionalDerivative, fmi3GetAdjointDerivative,
    fmi3EnterConfigurationMode, fmi3ExitConfigurationMode,
    fmi3GetIntervalDecimal, fmi3GetIntervalFraction, fmi3GetShiftDecimal, fmi3GetShiftFraction,
    fmi3SetIntervalDecimal, fmi3SetIntervalFraction, fmi3SetShiftDecimal, fmi3SetShiftFraction,
    fmi3EvaluateDiscreteStates, fmi3UpdateDiscreteStates,
    fmi3EnterContinuousTimeMode, fmi3CompletedIntegratorStep, fmi3SetTime,
    fmi3SetContinuousStates, fmi3GetContinuousStateDerivatives, fmi3GetEventIndicators,
    fmi3GetContinuousStates, fmi3GetNominalsOfContinuousStates,
    fmi3GetNumberOfEventIndicators, fmi3GetNumberOfContinuousStates,
    fmi3GetOutputDerivatives, fmi3ActivateModelPartition,
}
