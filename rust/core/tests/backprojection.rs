//! Integration tests of soft-shadow mapping by backprojection on maps whose side is not a power
//! of two: every pyramid level's micro-occluders reach past the map's last texel corner there.

mod common;

use common::{ground_and_cloud, ground_grid, rect_light_above};
use softshadows_core::methods::backprojection::{
    backprojection, Accumulation, BackprojectionOptions, Budget, Occluder,
};

#[test]
fn every_level_and_micro_occluder_backprojects_on_a_map_side_that_is_not_a_power_of_two(
) -> Result<(), String> {
    let (scene, light, receivers) = (ground_and_cloud(), rect_light_above(), ground_grid(12));
    for resolution in [60, 61, 97] {
        for occluder in [
            Occluder::Micropatch { extend: false },
            Occluder::Micropatch { extend: true },
            Occluder::Microquad,
            Occluder::Microrect,
        ] {
            for level in 0..=6 {
                for accumulation in [Accumulation::Area, Accumulation::Bitmask { side: 4 }] {
                    let opts = BackprojectionOptions {
                        resolution,
                        occluder,
                        accumulation,
                        budget: Budget::Infinite,
                        level: Some(level),
                        ..Default::default()
                    };
                    let (visibility, _) = backprojection(&scene, &light, &receivers, &opts)
                        .map_err(|e| format!("{opts:?}: {e}"))?;
                    assert!(
                        visibility.iter().all(|v| (0.0..=1.0).contains(v)),
                        "{opts:?}: {visibility:?}"
                    );
                    // The cloud shadows part of the ground at every level with room for a
                    // microquad (two texels a side or more).
                    if resolution >> level >= 2 {
                        assert!(visibility.iter().any(|&v| v < 1.0), "{opts:?}");
                    }
                }
            }
        }
    }
    Ok(())
}
