//! The `.fmu` archive: `modelDescription.xml`, the shared library under
//! `binaries/<platform>/`, the defaults under `resources/` and the documentation.

use std::io::Write;
use std::path::Path;

use crate::config::Defaults;
use crate::description::{FmiVersion, model_description};
use crate::{FmuError, MODEL_IDENTIFIER};

/// The documentation inside the archive (`documentation/index.html`).
const DOC: &str = include_str!("../doc/index.html");

/// Writes the FMU of `version` to `out`: the description of `defaults`, the shared library
/// `library` (this crate's cdylib for this platform) and the defaults as a resource.
///
/// # Errors
/// [`FmuError::Io`] naming the file that could not be read or written.
pub fn write_fmu(
    out: &Path,
    library: &Path,
    defaults: &Defaults,
    version: FmiVersion,
) -> Result<(), FmuError> {
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source: std::io::Error| FmuError::Io { path, source }
    };
    let zip_err = |path: &Path| {
        let path = path.to_path_buf();
        move |e: zip::result::ZipError| FmuError::Io {
            path,
            source: std::io::Error::other(e),
        }
    };
    let lib = std::fs::read(library).map_err(io(library))?;
    let description = model_description(defaults, version)?;
    let resource = serde_json::to_string_pretty(defaults)
        .map_err(|e| FmuError::parameter("<defaults>", e.to_string()))?;
    let platform = match version {
        FmiVersion::V2 => "linux64",
        FmiVersion::V3 => "x86_64-linux",
    };
    let tmp = out.with_extension("fmu.tmp");
    let file = std::fs::File::create(&tmp).map_err(io(&tmp))?;
    let mut zip = zip::ZipWriter::new(file);
    let options = zip::write::SimpleFileOptions::default()
        .compression_method(zip::CompressionMethod::Deflated);
    let entries: [(String, &[u8]); 4] = [
        ("modelDescription.xml".into(), description.as_bytes()),
        (
            format!("binaries/{platform}/{MODEL_IDENTIFIER}.so"),
            lib.as_slice(),
        ),
        ("resources/defaults.json".into(), resource.as_bytes()),
        ("documentation/index.html".into(), DOC.as_bytes()),
    ];
    for (name, bytes) in entries {
        zip.start_file(name, options).map_err(zip_err(&tmp))?;
        zip.write_all(bytes).map_err(io(&tmp))?;
    }
    zip.finish().map_err(zip_err(&tmp))?;
    std::fs::rename(&tmp, out).map_err(io(out))?;
    Ok(())
}
