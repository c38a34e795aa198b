//! `modelDescription.xml` for FMI 2.0 and FMI 3.0 Co-Simulation, from the variables of
//! [`crate::variables`].

use crate::config::Defaults;
use crate::variables::{Causality, Kind, Value, Variable, variables};
use crate::{FmuError, MODEL_IDENTIFIER};

/// The FMI version of a description or archive.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FmiVersion {
    /// FMI 2.0 (every importer)
    V2,
    /// FMI 3.0
    V3,
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn real(x: f64) -> String {
    format!("{x:?}")
}

fn start(value: &Value) -> String {
    match value {
        Value::Real(x) => real(*x),
        Value::Integer(i) => i.to_string(),
        Value::Boolean(b) => b.to_string(),
        Value::String(s) => escape(s),
    }
}

/// The instantiation token (FMI 2.0 guid): a hash of the defaults, so a description and a
/// resource of different builds are told apart.
pub fn token(defaults: &Defaults) -> String {
    let text = serde_json::to_string(defaults).unwrap_or_default();
    // FNV-1a, 64 bit
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in text.bytes() {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    format!("{{trailer-sway-{h:016x}}}")
}

const DESCRIPTION: &str = "Car-trailer combination (single-track model, brush tyres, paper: Controlling the nonlinear dynamics of trailer sway) with its delayed sway controller, integrated by trailer-sway's DDE solver";

/// The model description of version `version` for `defaults`.
///
/// # Errors
/// [`FmuError::Parameter`] if the defaults do not give variables.
pub fn model_description(defaults: &Defaults, version: FmiVersion) -> Result<String, FmuError> {
    let vars = variables(defaults)?;
    Ok(match version {
        FmiVersion::V2 => v2(defaults, &vars),
        FmiVersion::V3 => v3(defaults, &vars),
    })
}

fn attributes(v: &Variable, version: FmiVersion) -> String {
    let (causality, variability, initial) = match (v.causality, v.kind) {
        (Causality::Parameter, _) => ("parameter", "fixed", Some("exact")),
        (Causality::Input, _) => ("input", "continuous", None),
        (Causality::Output, Kind::Real) => ("output", "continuous", Some("calculated")),
        (Causality::Output, _) => ("output", "discrete", Some("calculated")),
        (Causality::Independent, _) => ("independent", "continuous", None),
    };
    let mut s = format!(
        "name=\"{}\" causality=\"{causality}\" variability=\"{variability}\"",
        escape(&v.name)
    );
    if let Some(i) = initial {
        s.push_str(&format!(" initial=\"{i}\""));
    }
    s.push_str(&format!(" description=\"{}\"", escape(&v.description)));
    let _ = version;
    s
}

fn v2(defaults: &Defaults, vars: &[Variable]) -> String {
    let mut x = String::new();
    x.push_str("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    x.push_str(&format!(
        "<fmiModelDescription fmiVersion=\"2.0\" modelName=\"{MODEL_IDENTIFIER}\" guid=\"{}\" description=\"{DESCRIPTION}\" generationTool=\"trailer-sway {}\" variableNamingConvention=\"flat\" numberOfEventIndicators=\"0\">\n",
        token(defaults),
        env!("CARGO_PKG_VERSION")
    ));
    x.push_str(&format!(
        "  <CoSimulation modelIdentifier=\"{MODEL_IDENTIFIER}\" needsExecutionTool=\"false\" canHandleVariableCommunicationStepSize=\"true\" canInterpolateInputs=\"false\" maxOutputDerivativeOrder=\"0\" canRunAsynchronuously=\"false\" canBeInstantiatedOnlyOncePerProcess=\"false\" canNotUseMemoryManagementFunctions=\"true\" canGetAndSetFMUstate=\"true\" canSerializeFMUstate=\"true\" providesDirectionalDerivative=\"false\"/>\n"
    ));
    x.push_str("  <DefaultExperiment startTime=\"0.0\" stopTime=\"60.0\" stepSize=\"0.01\"/>\n");
    x.push_str("  <ModelVariables>\n");
    for (vr, v) in vars.iter().enumerate() {
        x.push_str(&format!(
            "    <!-- {} -->\n    <ScalarVariable {} valueReference=\"{vr}\">\n",
            vr + 1,
            attributes(v, FmiVersion::V2)
        ));
        let tag = v.kind.fmi2_name();
        match &v.start {
            Some(s) => x.push_str(&format!("      <{tag} start=\"{}\"/>\n", start(s))),
            None => x.push_str(&format!("      <{tag}/>\n")),
        }
        x.push_str("    </ScalarVariable>\n");
    }
    x.push_str("  </ModelVariables>\n  <ModelStructure>\n    <Outputs>\n");
    let outputs: Vec<usize> = vars
        .iter()
        .enumerate()
        .filter(|(_, v)| v.causality == Causality::Output)
        .map(|(i, _)| i + 1)
        .collect();
    for i in &outputs {
        x.push_str(&format!("      <Unknown index=\"{i}\"/>\n"));
    }
    x.push_str("    </Outputs>\n    <InitialUnknowns>\n");
    for i in &outputs {
        x.push_str(&format!("      <Unknown index=\"{i}\"/>\n"));
    }
    x.push_str("    </InitialUnknowns>\n  </ModelStructure>\n</fmiModelDescription>\n");
    x
}

fn v3(defaults: &Defaults, vars: &[Variable]) -> String {
    let mut x = String::new();
    x.push_str("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    x.push_str(&format!(
        "<fmiModelDescription fmiVersion=\"3.0\" modelName=\"{MODEL_IDENTIFIER}\" instantiationToken=\"{}\" description=\"{DESCRIPTION}\" generationTool=\"trailer-sway {}\" variableNamingConvention=\"flat\">\n",
        token(defaults),
        env!("CARGO_PKG_VERSION")
    ));
    x.push_str(&format!(
        "  <CoSimulation modelIdentifier=\"{MODEL_IDENTIFIER}\" canHandleVariableCommunicationStepSize=\"true\" canGetAndSetFMUState=\"true\" canSerializeFMUState=\"true\" providesDirectionalDerivatives=\"false\" providesAdjointDerivatives=\"false\" hasEventMode=\"false\" providesIntermediateUpdate=\"false\"/>\n"
    ));
    x.push_str("  <DefaultExperiment startTime=\"0.0\" stopTime=\"60.0\" stepSize=\"0.01\"/>\n");
    x.push_str("  <ModelVariables>\n");
    for (vr, v) in vars.iter().enumerate() {
        let tag = match v.kind {
            Kind::Real => "Float64",
            Kind::Integer => "Int32",
            Kind::Boolean => "Boolean",
            Kind::String => "String",
        };
        let attrs = attributes(v, FmiVersion::V3);
        match (&v.start, v.kind) {
            (Some(s), Kind::String) => x.push_str(&format!(
                "    <{tag} {attrs} valueReference=\"{vr}\">\n      <Start value=\"{}\"/>\n    </{tag}>\n",
                start(s)
            )),
            (Some(s), _) => x.push_str(&format!(
                "    <{tag} {attrs} valueReference=\"{vr}\" start=\"{}\"/>\n",
                start(s)
            )),
            (None, _) => x.push_str(&format!("    <{tag} {attrs} valueReference=\"{vr}\"/>\n")),
        }
    }
    x.push_str("  </ModelVariables>\n  <ModelStructure>\n");
    let outputs: Vec<usize> = vars
        .iter()
        .enumerate()
        .filter(|(_, v)| v.causality == Causality::Output)
        .map(|(i, _)| i)
        .collect();
    for vr in &outputs {
        x.push_str(&format!("    <Output valueReference=\"{vr}\"/>\n"));
    }
    for vr in &outputs {
        x.push_str(&format!("    <InitialUnknown valueReference=\"{vr}\"/>\n"));
    }
    x.push_str("  </ModelStructure>\n</fmiModelDescription>\n");
    x
}
