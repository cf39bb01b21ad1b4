//! Which receivers lie inside a closed mesh: the receivers for which the bias-free culling of
//! closed casters (Sintorn, Eisemann and Assarsson 2008, section 3.3: only light back-facing
//! triangles cast) does not hold. A segment from outside a closed mesh that crosses it enters
//! through a triangle it meets from the front; from inside, it first leaves through one it meets
//! from the back, which culling drops. `alias_free` and `ray_traced(caster_faces="backfacing")` test
//! the receivers found here against every triangle, from their moved point.

use crate::error::Result;
use crate::geometry::bvh::Bvh;
use crate::geometry::mesh::Scene;
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use std::borrow::Cow;

/// How far along its normal a receiver is probed for lying inside a closed mesh, at least: this
/// fraction of the scene's diagonal, a tenth of `ray_traced`'s default offset, so that a
/// receiver on a closed mesh's surface facing out probes outside it even without a bias, as the
/// paper's bias-free culling assumes.
const INSIDE_PROBE: f64 = 1e-5;

/// Two directions of rays from a probed point, along no axis or diagonal of a regular grid: the
/// watertight test counts a ray through a shared edge or vertex on both triangles, so a ray
/// that grazes one finds the wrong parity; two such rays at once are left to chance.
const INSIDE_RAYS: [Vec3; 2] = [
    Vec3::new(0.289_1, 0.836_7, 0.465_1),
    Vec3::new(-0.613_6, 0.178_9, -0.769_1),
];

/// For each receiver `(p, n)` moved `bias` along its normal, whether it lies inside a closed
/// mesh of `scene`: probed [`INSIDE_PROBE`] or `bias` along the normal, whichever is farther,
/// within a closed mesh's bounding box, with some of the mesh's faces on the first of the
/// [`INSIDE_RAYS`] and an odd number on either. The BVH comes from `bvh`, called only when some
/// probe lies in a box. A receiver flagged though outside only tests more triangles, and
/// exactly; one inside the mesh and missed would see the light through it.
pub fn inside_closed_meshes<'b>(
    scene: &Scene,
    receivers: &[(DVec3, DVec3)],
    bias: f64,
    bvh: impl FnOnce() -> Result<Cow<'b, Bvh>>,
) -> Result<Vec<bool>> {
    let boxes = closed_mesh_boxes(scene);
    let (lo, hi) = scene.bounds();
    let least = INSIDE_PROBE * (hi - lo).as_dvec3().length();
    let probes: Vec<DVec3> = receivers
        .iter()
        .map(|&(p, n)| p + n / n.length() * bias.max(least))
        .collect();
    let in_box =
        |q: DVec3, (_, lo, hi): &(u32, DVec3, DVec3)| q.cmpge(*lo).all() && q.cmple(*hi).all();
    if !probes.iter().any(|&q| boxes.iter().any(|b| in_box(q, b))) {
        return Ok(vec![false; receivers.len()]);
    }
    let bvh = bvh()?;
    // A ray that meets none of a closed mesh's faces proves its origin outside the mesh: from
    // inside, every ray leaves through a face (the watertight test lets none slip between two),
    // so the second ray is cast only after a first that met some.
    let odd = |q: DVec3, (mesh, lo, hi): &(u32, DVec3, DVec3)| {
        let reach = 2.0 * (*hi - *lo).length() as f32 + 1.0;
        let hits =
            |d: Vec3| bvh.count_hits(q.as_vec3(), d, reach, |f| scene.face_ref(f).mesh == *mesh);
        match hits(INSIDE_RAYS[0]) {
            0 => false,
            first if first % 2 == 1 => true,
            _ => hits(INSIDE_RAYS[1]) % 2 == 1,
        }
    };
    Ok(probes
        .par_iter()
        .map(|&q| boxes.iter().any(|b| in_box(q, b) && odd(q, b)))
        .collect())
}

/// The closed meshes with faces: index and bounding box of the vertices their faces use.
fn closed_mesh_boxes(scene: &Scene) -> Vec<(u32, DVec3, DVec3)> {
    scene
        .meshes
        .iter()
        .enumerate()
        .filter(|(_, m)| m.closed && !m.faces.is_empty())
        .map(|(k, m)| {
            let corners = m
                .faces
                .iter()
                .flatten()
                .map(|&v| m.positions[v as usize].as_dvec3());
            let (lo, hi) = corners.fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(p), hi.max(p))
            });
            (k as u32, lo, hi)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::mesh::Mesh;

    #[test]
    fn points_are_inside_a_closed_tetrahedron_where_its_planes_say() -> Result<()> {
        // A grid over the tetrahedron's box (most rays from the points outside meet no face,
        // some meet two): flagged exactly where the point lies inside, away from the faces.
        let tet = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
        let faces = vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
        let scene = Scene::new(vec![Mesh::new(tet, faces, None, None, true)?])?;
        let bvh = Bvh::build(&scene)?;
        let grid: Vec<DVec3> = (0..9)
            .flat_map(|i| {
                (0..9).flat_map(move |j| {
                    (0..9).map(move |k| DVec3::new(i as f64, j as f64, k as f64))
                })
            })
            .map(|c| (c + 0.37) / 9.0)
            .filter(|p| (p.x + p.y + p.z - 1.0).abs() > 0.01)
            .collect();
        let receivers: Vec<(DVec3, DVec3)> = grid.iter().map(|&p| (p, DVec3::X)).collect();
        let inside = inside_closed_meshes(&scene, &receivers, 0.0, || Ok(Cow::Borrowed(&bvh)))?;
        let expected: Vec<bool> = grid.iter().map(|p| p.x + p.y + p.z < 1.0).collect();
        assert_eq!(inside, expected);
        assert!(expected.iter().any(|&e| e) && expected.iter().any(|&e| !e));
        Ok(())
    }
}
