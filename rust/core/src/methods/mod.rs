//! One module per soft-shadow method, named as in the Python API.
pub mod alias_free;
pub mod backprojection;
pub mod cssm;
pub mod dcs;
pub mod denoised;
pub mod mvr;
pub mod pcss;
pub mod penumbra_wedge;
pub mod ray_traced;
pub mod shadow_map;
pub mod stsv;
pub mod vwss;

use crate::error::{Error, Result};
use crate::light::lights::Light;

/// Every method's own stats keys by its Python name (its module's `STATS`; every call also
/// returns [`crate::stats::COMMON`]).
pub const STATS: &[(&str, &[&str])] = &[
    ("ray_traced", ray_traced::STATS),
    ("shadow_map", shadow_map::STATS),
    ("mvr", mvr::STATS),
    ("vwss", vwss::STATS),
    ("pcss", pcss::STATS),
    ("backprojection", backprojection::STATS),
    ("cssm", cssm::STATS),
    ("alias_free", alias_free::STATS),
    ("dcs", dcs::STATS),
    ("penumbra_wedge", penumbra_wedge::STATS),
    ("stsv", stsv::STATS),
    ("denoised", denoised::STATS),
];

/// Which triangles of closed meshes cast shadows (`alias_free`, `ray_traced`, `stsv`'s bitmasks).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CasterFaces {
    /// Closed meshes: light back-facing triangles only, from the receiver itself with no offset
    /// (bias-free; Sintorn, Eisemann and Assarsson 2008, section 3.3), but every triangle, from
    /// the moved receiver, for the receivers inside one ([`crate::geometry::inside`]); open
    /// meshes: every triangle, from the moved receiver.
    #[default]
    Backfacing,
    /// Every triangle, from the receiver moved along its normal (`docs/design.md` section 3).
    All,
}

/// Refuses an emission-textured light for the methods that filter one shadow map seen from the
/// light's center (`shadow_map`, `pcss`, `cssm`, `backprojection`): they have no light samples
/// to weight by the texture, and a prefiltered map cannot carry it (Annen et al. 2008, section
/// 4.2: textured sources are decomposed into uniform lights instead).
pub(crate) fn refuse_textured(light: &Light, method: &str) -> Result<()> {
    if light.is_textured() {
        return Err(Error::unsupported(
            "light",
            format!(
                "{method} cannot weight the light's emission texture (it filters one shadow map from the light's center); \
                 use ray_traced, alias_free, stsv, dcs, penumbra_wedge, mvr or vwss, which weight every light sample by it, \
                 or a light without emission"
            ),
        ));
    }
    Ok(())
}
