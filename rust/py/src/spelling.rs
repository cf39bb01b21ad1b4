//! The spellings of the Python API's enum options, each declared once here, and the one
//! extractor that reads them: a misspelling is a `ValueError` naming the option and its values.
//! (Python checks only that an option is a string; the core sees the enum.)

use crate::error::OrRaise;
use pyo3::prelude::*;
use pyo3::Borrowed;
use softshadows_core::backend::Backend;
use softshadows_core::light::sampling::Pattern;
use softshadows_core::methods::cssm::Prefilter;
use softshadows_core::methods::stsv::Opaque;
use softshadows_core::methods::vwss::{Mode, Parallel, Precision, SourceView};
use softshadows_core::methods::CasterFaces;
use softshadows_core::{Error, Result};

/// A core enum as the Python API spells it.
pub trait Spelled: Copy + 'static {
    /// The keyword argument that takes it, named by the error of a misspelling.
    const OPTION: &'static str;
    /// Every value by its spelling, in the order the documentation lists them.
    const SPELLINGS: &'static [(&'static str, Self)];
}

/// An enum option extracted from its Python string: `mode: Spelling<Mode>` in a signature.
pub struct Spelling<T>(pub T);

impl<'a, 'py, T: Spelled> FromPyObject<'a, 'py> for Spelling<T> {
    type Error = PyErr;

    fn extract(obj: Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        let value: String = obj.extract()?;
        choice(T::OPTION, &value, T::SPELLINGS)
            .map(Spelling)
            .or_raise()
    }
}

/// The value spelled `value` among `options`, or the error naming `option` and every spelling;
/// also for the options whose values carry data from other arguments (backprojection's).
pub fn choice<T: Copy>(option: &str, value: &str, options: &[(&str, T)]) -> Result<T> {
    options
        .iter()
        .find(|(name, _)| *name == value)
        .map(|(_, v)| *v)
        .ok_or_else(|| {
            let names: Vec<String> = options.iter().map(|(n, _)| format!("{n:?}")).collect();
            Error::invalid(
                option,
                format!("expected one of {}, got {value:?}", names.join(", ")),
            )
        })
}

impl Spelled for Backend {
    const OPTION: &'static str = "backend";
    // Python resolves "auto" before the call.
    const SPELLINGS: &'static [(&'static str, Self)] = &[("cpu", Self::Cpu), ("gpu", Self::Gpu)];
}

impl Spelled for CasterFaces {
    const OPTION: &'static str = "caster_faces";
    const SPELLINGS: &'static [(&'static str, Self)] =
        &[("backfacing", Self::Backfacing), ("all", Self::All)];
}

impl Spelled for Pattern {
    const OPTION: &'static str = "pattern";
    const SPELLINGS: &'static [(&'static str, Self)] = &[
        ("uniform", Self::Uniform),
        ("stratified", Self::Stratified),
        ("poisson", Self::Poisson),
        ("sobol", Self::Sobol),
        ("halton", Self::Halton),
    ];
}

impl Spelled for Prefilter {
    const OPTION: &'static str = "prefilter";
    const SPELLINGS: &'static [(&'static str, Self)] =
        &[("sat", Self::Sat), ("mipmap", Self::Mipmap)];
}

impl Spelled for Opaque {
    const OPTION: &'static str = "opaque";
    const SPELLINGS: &'static [(&'static str, Self)] = &[
        ("bitmask", Self::Bitmask),
        ("dcs", Self::Dcs),
        ("penumbra_wedge", Self::PenumbraWedge),
    ];
}

impl Spelled for Mode {
    const OPTION: &'static str = "mode";
    const SPELLINGS: &'static [(&'static str, Self)] = &[
        ("buffered", Self::Buffered),
        ("unbuffered", Self::Unbuffered),
    ];
}

impl Spelled for Parallel {
    const OPTION: &'static str = "parallel";
    const SPELLINGS: &'static [(&'static str, Self)] = &[
        ("serial", Self::Serial),
        ("partial", Self::Partial),
        ("full", Self::Full),
    ];
}

impl Spelled for Precision {
    const OPTION: &'static str = "precision";
    const SPELLINGS: &'static [(&'static str, Self)] =
        &[("float32", Self::Float32), ("float16", Self::Float16)];
}

impl Spelled for SourceView {
    const OPTION: &'static str = "source_view";
    const SPELLINGS: &'static [(&'static str, Self)] =
        &[("fitted", Self::Fitted), ("paper", Self::Paper)];
}
