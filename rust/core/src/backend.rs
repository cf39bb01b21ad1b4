//! Where a method runs: the choice every method with a GPU half takes per call.

/// Where a method runs. [`Backend::Gpu`] runs the method's compute pipelines ([`crate::gpu`]);
/// built without the crate feature `gpu`, it answers [`crate::Error::Unavailable`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Backend {
    #[default]
    Cpu,
    Gpu,
}
