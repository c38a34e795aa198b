//! The C boundary shared by FMI 2.0 and 3.0: the component behind an instance pointer,
//! the logger, the resource location, and [`call`], which every entry point goes through:
//! it checks the pointer, catches any panic (`catch_unwind`) and turns errors into the
//! status `Error` with the message logged, so nothing unwinds into the importer.

use std::ffi::{CStr, CString, c_char, c_void};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::PathBuf;

use crate::FmuError;
use crate::config::Defaults;
use crate::instance::Instance;

pub mod fmi2;
pub mod fmi3;

/// fmi2Status / fmi3Status (the same numbers for OK … Fatal).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(i32)]
pub enum Status {
    /// all well
    Ok = 0,
    /// done, with a message
    Warning = 1,
    /// the step could not be completed (a loss of control)
    Discard = 2,
    /// the call failed; the instance may be used after a reset or a restored state
    Error = 3,
    /// the instance is unusable
    Fatal = 4,
}

/// FMI 2.0's variadic logger.
pub type Fmi2Logger =
    unsafe extern "C" fn(*mut c_void, *const c_char, i32, *const c_char, *const c_char, ...);
/// FMI 3.0's logger.
pub type Fmi3Logger = unsafe extern "C" fn(*mut c_void, i32, *const c_char, *const c_char);

/// Where messages go.
#[derive(Debug, Clone, Copy)]
pub enum Logger {
    /// FMI 2.0 callback and environment
    V2(Option<Fmi2Logger>, *mut c_void),
    /// FMI 3.0 callback and environment
    V3(Option<Fmi3Logger>, *mut c_void),
}

/// What an instance pointer points to.
#[derive(Debug)]
pub struct Component {
    /// the instance name
    pub name: CString,
    /// the instance
    pub instance: Instance,
    /// the importer's logger
    pub logger: Logger,
    /// whether debug messages are wanted
    pub logging: bool,
    /// strings handed out by GetString (valid until the next call)
    pub strings: Vec<CString>,
    /// where the last step ended \[s\] (fmi2LastSuccessfulTime)
    pub last_successful_s: f64,
    /// the FMU asked to end the simulation (loss of control)
    pub terminated: bool,
}

impl Component {
    /// Back to the start values (fmi2Reset, fmi3Reset).
    pub fn reset(&mut self) {
        self.instance.reset();
        self.terminated = false;
        self.last_successful_s = 0.0;
    }

    /// Sends `message` to the importer's logger.
    pub fn log(&self, status: Status, category: &str, message: &str) {
        let category = CString::new(category).unwrap_or_default();
        let message = CString::new(message.replace('\0', " ")).unwrap_or_default();
        match self.logger {
            Logger::V2(Some(f), env) => {
                // SAFETY: the importer's callback with the C strings it expects; the
                // message goes through "%s", so a '%' in it is not a format directive.
                unsafe {
                    f(
                        env,
                        self.name.as_ptr(),
                        status as i32,
                        category.as_ptr(),
                        c"%s".as_ptr(),
                        message.as_ptr(),
                    )
                }
            }
            // SAFETY: the importer's callback with the C strings it expects
            Logger::V3(Some(f), env) => unsafe {
                f(env, status as i32, category.as_ptr(), message.as_ptr())
            },
            _ => {}
        }
    }
}

/// A C string argument (empty for null).
///
/// # Safety
/// `s` is null or a NUL-terminated string.
pub unsafe fn text(s: *const c_char) -> String {
    if s.is_null() {
        String::new()
    } else {
        // SAFETY: the caller's contract
        unsafe { CStr::from_ptr(s) }.to_string_lossy().into_owned()
    }
}

/// The resource directory of an FMI 2.0 `fmuResourceLocation` (a `file:` URI) or an FMI
/// 3.0 `resourcePath` (a path).
pub fn resource_dir(location: &str) -> Option<PathBuf> {
    if location.is_empty() {
        return None;
    }
    let path = match location.strip_prefix("file:") {
        Some(rest) => {
            let rest = rest.strip_prefix("//localhost").unwrap_or(rest);
            let rest = if rest.starts_with("///") {
                &rest[2..]
            } else {
                rest
            };
            let rest = rest.strip_prefix("//").map_or(rest, |r| r);
            percent_decode(rest)
        }
        None => location.to_string(),
    };
    Some(PathBuf::from(path))
}

fn percent_decode(s: &str) -> String {
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%'
            && i + 2 < bytes.len()
            && let Ok(hex) = std::str::from_utf8(&bytes[i + 1..i + 3])
            && let Ok(b) = u8::from_str_radix(hex, 16)
        {
            out.push(b);
            i += 3;
            continue;
        }
        out.push(bytes[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// The defaults of the archive (`resources/defaults.json`), or Table I's when the importer
/// gives no resource location (with the warning to log).
pub fn load_defaults(location: &str) -> Result<(Defaults, Option<String>), FmuError> {
    let Some(dir) = resource_dir(location) else {
        return Ok((
            Defaults::default(),
            Some("no resource location given: Table I's defaults".into()),
        ));
    };
    let path = dir.join("defaults.json");
    match std::fs::read_to_string(&path) {
        Ok(text) => serde_json::from_str(&text)
            .map(|d| (d, None))
            .map_err(|e| FmuError::Io {
                path,
                source: std::io::Error::other(e),
            }),
        Err(e) => Ok((
            Defaults::default(),
            Some(format!(
                "{}: {e}: Table I's defaults (the description may not match)",
                path.display()
            )),
        )),
    }
}

/// A new component on the heap, as the instance pointer.
pub fn instantiate(name: String, location: &str, logger: Logger, logging: bool) -> *mut Component {
    let result = catch_unwind(AssertUnwindSafe(|| -> Result<Box<Component>, FmuError> {
        let (defaults, warning) = load_defaults(location)?;
        let c = Box::new(Component {
            name: CString::new(name.replace('\0', " ")).unwrap_or_default(),
            instance: Instance::new(defaults)?,
            logger,
            logging,
            strings: Vec::new(),
            last_successful_s: 0.0,
            terminated: false,
        });
        if let Some(w) = warning {
            c.log(Status::Warning, "logStatusWarning", &w);
        }
        Ok(c)
    }));
    match result {
        Ok(Ok(c)) => Box::into_raw(c),
        Ok(Err(e)) => {
            let c = Component {
                name: CString::new(name).unwrap_or_default(),
                instance: match Instance::new(Defaults::default()) {
                    Ok(i) => i,
                    Err(_) => return std::ptr::null_mut(),
                },
                logger,
                logging,
                strings: Vec::new(),
                last_successful_s: 0.0,
                terminated: false,
            };
            c.log(Status::Error, "logStatusError", &e.to_string());
            std::ptr::null_mut()
        }
        Err(_) => std::ptr::null_mut(),
    }
}

/// Frees a component made by [`instantiate`].
///
/// # Safety
/// `c` is null or a pointer from [`instantiate`] not freed before.
pub unsafe fn free(c: *mut Component) {
    if !c.is_null() {
        let _ = catch_unwind(AssertUnwindSafe(|| {
            // SAFETY: the caller's contract
            drop(unsafe { Box::from_raw(c) });
        }));
    }
}

fn panic_message(p: &(dyn std::any::Any + Send)) -> String {
    p.downcast_ref::<&str>()
        .map(|s| (*s).to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "a panic".into())
}

/// Runs `f` on the component behind `c`: a null pointer is `Fatal`, an error is logged and
/// `Error`, a panic is caught, logged and `Error`; `f`'s own status otherwise.
///
/// # Safety
/// `c` is null or a live pointer from [`instantiate`], used by one thread at a time (the
/// FMI standard's rule for an instance).
pub unsafe fn call(
    c: *mut Component,
    what: &str,
    f: impl FnOnce(&mut Component) -> Result<Status, FmuError>,
) -> Status {
    if c.is_null() {
        return Status::Fatal;
    }
    // SAFETY: the caller's contract
    let component = unsafe { &mut *c };
    let result = catch_unwind(AssertUnwindSafe(|| f(component)));
    // SAFETY: as above (the closure's borrow has ended)
    let component = unsafe { &mut *c };
    match result {
        Ok(Ok(status)) => status,
        Ok(Err(e)) => {
            component.log(Status::Error, "logStatusError", &format!("{what}: {e}"));
            Status::Error
        }
        Err(p) => {
            let e = FmuError::Panic(panic_message(&*p));
            component.log(Status::Error, "logStatusError", &format!("{what}: {e}"));
            Status::Error
        }
    }
}

/// A slice from a C array (empty for n = 0, whatever the pointer).
///
/// # Safety
/// `p` points to `n` readable elements when `n > 0`.
pub unsafe fn slice<'a, T>(p: *const T, n: usize) -> Result<&'a [T], FmuError> {
    if n == 0 {
        return Ok(&[]);
    }
    if p.is_null() {
        return Err(FmuError::ValueReference {
            vr: 0,
            problem: "a null array".into(),
        });
    }
    // SAFETY: the caller's contract
    Ok(unsafe { std::slice::from_raw_parts(p, n) })
}

/// A mutable slice from a C array.
///
/// # Safety
/// `p` points to `n` writable elements when `n > 0`.
pub unsafe fn slice_mut<'a, T>(p: *mut T, n: usize) -> Result<&'a mut [T], FmuError> {
    if n == 0 {
        return Ok(&mut []);
    }
    if p.is_null() {
        return Err(FmuError::ValueReference {
            vr: 0,
            problem: "a null array".into(),
        });
    }
    // SAFETY: the caller's contract
    Ok(unsafe { std::slice::from_raw_parts_mut(p, n) })
}

/// One communication step with the FMI semantics: Ok, or Discard with `terminated` set on
/// a loss of control (logged).
pub fn do_step(c: &mut Component, t: f64, h: f64) -> Result<Status, FmuError> {
    if c.terminated {
        return Ok(Status::Discard);
    }
    match c.instance.do_step(t, h)? {
        None => {
            c.last_successful_s = t + h;
            Ok(Status::Ok)
        }
        Some((t_lost, why)) => {
            c.last_successful_s = t_lost;
            c.terminated = true;
            c.log(
                Status::Discard,
                "logStatusDiscard",
                &format!(
                    "loss of control at t = {t_lost} s ({why}): the model is not valid beyond; the simulation ends there"
                ),
            );
            Ok(Status::Discard)
        }
    }
}

/// Reads real variables.
pub fn get_reals(c: &mut Component, vr: &[u32], out: &mut [f64]) -> Result<Status, FmuError> {
    use crate::variables::{Kind, Value};
    for (r, o) in vr.iter().zip(out.iter_mut()) {
        if let Value::Real(x) = c.instance.get(*r, Kind::Real)? {
            *o = x;
        }
    }
    Ok(Status::Ok)
}

/// Writes real variables.
pub fn set_reals(c: &mut Component, vr: &[u32], values: &[f64]) -> Result<Status, FmuError> {
    use crate::variables::Value;
    for (r, x) in vr.iter().zip(values) {
        c.instance.set(*r, Value::Real(*x))?;
    }
    Ok(Status::Ok)
}
