//! The `.fmu` archive: `modelDescription.xml`, the shared library under
//! `binaries/<platform>/`, the defaults under `resources/` and the documentation.
//!
//! The archive's bytes depend only on their inputs (every entry dated 1980-01-01, the zip
//! format's zero), so the same library and defaults give the same file.

use std::io::Write;
use std::path::Path;

use crate::config::Defaults;
use crate::description::{FmiVersion, model_description};
use crate::{FmuError, MODEL_IDENTIFIER};

/// The documentation inside the archive (`documentation/index.html`).
const DOC: &str = include_str!("../doc/index.html");

/// The platform folder of `binaries/` for `version` (this crate builds for x86-64 Linux).
pub fn platform(version: FmiVersion) -> &'static str {
    match version {
        FmiVersion::V2 => "linux64",
        FmiVersion::V3 => "x86_64-linux",
    }
}

/// The archive of `version` as bytes: the description of `defaults`, the shared library
/// `library` (the bytes of this crate's cdylib for this platform) and the defaults as a
/// resource.
///
/// # Errors
/// [`FmuError::Parameter`] if the defaults do not describe an FMU; [`FmuError::Io`]
/// (path `<archive>`) if the zip writer fails.
pub fn fmu_bytes(
    library: &[u8],
    defaults: &Defaults,
    version: FmiVersion,
) -> Result<Vec<u8>, FmuError> {
    let zip_err = |e: zip::result::ZipError| FmuError::Io {
        path: "<archive>".into(),
        source: std::io::Error::other(e),
    };
    let description = model_description(defaults, version)?;
    let resource = serde_json::to_string_pretty(defaults)
        .map_err(|e| FmuError::parameter("<defaults>", e.to_string()))?;
    let mut zip = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let options = zip::write::SimpleFileOptions::default()
        .compression_method(zip::CompressionMethod::Deflated);
    let entries: [(String, &[u8]); 4] = [
        ("modelDescription.xml".into(), description.as_bytes()),
        (
            format!("binaries/{}/{MODEL_IDENTIFIER}.so", platform(version)),
            library,
        ),
        ("resources/defaults.json".into(), resource.as_bytes()),
        ("documentation/index.html".into(), DOC.as_bytes()),
    ];
    for (name, bytes) in entries {
        zip.start_file(name, options).map_err(zip_err)?;
        zip.write_all(bytes).map_err(|source| FmuError::Io {
            path: "<archive>".into(),
            source,
        })?;
    }
    Ok(zip.finish().map_err(zip_err)?.into_inner())
}

/// Writes the FMU of `version` to `out` ([`fmu_bytes`] of the shared library file
/// `library`), through a temporary file renamed into place.
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
    let lib = std::fs::read(library).map_err(io(library))?;
    let bytes = fmu_bytes(&lib, defaults, version)?;
    let tmp = out.with_extension("fmu.tmp");
    std::fs::write(&tmp, bytes).map_err(io(&tmp))?;
    std::fs::rename(&tmp, out).map_err(io(out))?;
    Ok(())
}
