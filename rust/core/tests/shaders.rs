//! Validation of every WGSL shader with naga, so a broken shader fails `cargo test` on machines
//! without a GPU. Each shader is checked as the GPU backend compiles it: prefixed with the shared
//! helpers it reads.

use naga::valid::{Capabilities, ValidationFlags, Validator};

/// The light-frustum helpers every frustum-reading shader is prefixed with.
const FRUSTUM: &str = include_str!("../src/gpu/frustum.wgsl");
/// The f64 vector helpers of the shaders that repeat the CPU's f64 arithmetic.
const VECTOR64: &str = include_str!("../src/gpu/vector64.wgsl");

/// Parses and validates the shader made of `parts`, failing with naga's message.
fn validates(name: &str, parts: &[&str], capabilities: Capabilities) {
    let source = parts.join("\n");
    let module = naga::front::wgsl::parse_str(&source)
        .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(&source)));
    Validator::new(ValidationFlags::all(), capabilities)
        .validate(&module)
        .unwrap_or_else(|e| panic!("{name}: {e:?}"));
}

#[test]
fn multiview_shader_validates() {
    let shader = include_str!("../src/gpu/multiview.wgsl");
    validates("multiview.wgsl", &[FRUSTUM, shader], Capabilities::empty());
}

#[test]
fn vwss_shader_validates() {
    let shader = include_str!("../src/methods/vwss/vwss.wgsl");
    validates("vwss.wgsl", &[FRUSTUM, shader], Capabilities::empty());
}

#[test]
fn pcss_shader_validates() {
    let shader = include_str!("../src/methods/pcss/pcss.wgsl");
    validates("pcss.wgsl", &[FRUSTUM, shader], Capabilities::FLOAT64);
}

#[test]
fn cssm_shader_validates() {
    let shader = include_str!("../src/methods/cssm/cssm.wgsl");
    validates("cssm.wgsl", &[shader], Capabilities::FLOAT64);
}

#[test]
fn mvr_shader_validates() {
    let shader = include_str!("../src/methods/mvr/mvr.wgsl");
    validates(
        "mvr.wgsl",
        &[FRUSTUM, VECTOR64, shader],
        Capabilities::FLOAT64,
    );
}

#[test]
fn alias_free_shader_validates() {
    let shader = include_str!("../src/methods/alias_free/alias_free.wgsl");
    validates(
        "alias_free.wgsl",
        &[FRUSTUM, VECTOR64, shader],
        Capabilities::FLOAT64,
    );
}
