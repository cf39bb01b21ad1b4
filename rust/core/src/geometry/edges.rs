//! Edge adjacency of a scene's meshes and the light's potential silhouette edges.
//!
//! Every edge of every mesh appears once, with the faces that share it (by vertex index, so an
//! unwelded mesh is all boundary edges: conservative, never wrong). An edge is a *silhouette* as
//! seen from a point `y` when its two faces fold back: their third vertices lie on the same side
//! of the plane through `y` and the edge. This test does not depend on how the faces are wound.
//! A *potential* silhouette of a light is an edge that is a silhouette from some point of the
//! light: occlusion as seen from a receiver can only change across the light where a segment to
//! the light crosses one (Sintorn et al. 2008, section 4.3; Akenine-Möller and Assarsson 2005).

use crate::geometry::mesh::Scene;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// One edge of a mesh: its end points, up to two faces that share it (global ids), and how many
/// faces share it (1: a boundary edge; 3 or more: a non-manifold edge).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Edge {
    pub ends: [Vec3; 2],
    /// The third vertex of each of the first two faces.
    pub opposite: [Vec3; 2],
    pub faces: [u32; 2],
    pub shared_by: u32,
}

/// Every edge of `scene`, mesh by mesh, in order of their sorted vertex indices.
pub fn edges(scene: &Scene) -> Vec<Edge> {
    let mut out = Vec::new();
    let mut first_face = 0u32;
    for mesh in &scene.meshes {
        let mut keyed: Vec<(u64, u32, u32)> = mesh
            .faces
            .iter()
            .enumerate()
            .flat_map(|(f, v)| {
                (0..3).map(move |k| {
                    let (a, b) = (v[k].min(v[(k + 1) % 3]), v[k].max(v[(k + 1) % 3]));
                    ((u64::from(a) << 32) | u64::from(b), f as u32, v[(k + 2) % 3])
                })
            })
            .collect();
        keyed.par_sort_unstable();
        let pos = |i: u32| mesh.positions[i as usize];
        for group in keyed.chunk_by(|x, y| x.0 == y.0) {
            let (a, b) = ((group[0].0 >> 32) as u32, group[0].0 as u32);
            let second = group.get(1).unwrap_or(&group[0]);
            out.push(Edge {
                ends: [pos(a), pos(b)],
                opposite: [pos(group[0].2), pos(second.2)],
                faces: [first_face + group[0].1, first_face + second.1],
                shared_by: group.len() as u32,
            });
        }
        first_face += mesh.faces.len() as u32;
    }
    out
}

impl Edge {
    /// Whether some point of the ball `(center, radius)` sees this edge as a silhouette (always
    /// for a boundary or non-manifold edge). Exact for a point light (`radius` 0); for a ball,
    /// the edge is cleared only when the ball lies strictly on one side of both face planes and
    /// on the side where the faces do not fold back.
    pub fn is_potential_silhouette(&self, center: DVec3, radius: f64) -> bool {
        if self.shared_by != 2 {
            return true;
        }
        let [a, b] = self.ends.map(|p| p.as_dvec3());
        let [c1, c2] = self.opposite.map(|p| p.as_dvec3());
        // The faces as if wound consistently, (a, b, c1) and (b, a, c2): seen from y they fold
        // back exactly when y lies on different sides of their planes.
        let n1 = (b - a).cross(c1 - a);
        let n2 = (a - b).cross(c2 - a);
        let side = |n: DVec3| {
            let d = n.dot(center - a);
            let r = radius * n.length();
            if d > r {
                1
            } else if d < -r {
                -1
            } else {
                0
            }
        };
        let (s1, s2) = (side(n1), side(n2));
        s1 == 0 || s1 != s2
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::mesh::Mesh;

    /// A closed tetrahedron and an open quad of two triangles.
    fn scene() -> Scene {
        let tet = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
        let faces = vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
        let quad = vec![Vec3::new(-2.0, -1.0, -2.0), Vec3::new(2.0, -1.0, -2.0), Vec3::new(2.0, -1.0, 2.0), Vec3::new(-2.0, -1.0, 2.0)];
        Scene::new(vec![
            Mesh::new(tet, faces, None, None, true).unwrap(),
            Mesh::new(quad, vec![[0, 1, 2], [0, 2, 3]], None, None, false).unwrap(),
        ])
        .unwrap()
    }

    #[test]
    fn every_edge_once_with_its_faces() {
        let e = edges(&scene());
        assert_eq!(e.len(), 6 + 5);
        assert!(e[..6].iter().all(|e| e.shared_by == 2 && e.faces[0] != e.faces[1] && e.faces.iter().all(|&f| f < 4)));
        assert_eq!(e[6..].iter().filter(|e| e.shared_by == 1).count(), 4);
        let diagonal = e[6..].iter().find(|e| e.shared_by == 2).unwrap();
        assert_eq!(diagonal.faces, [4, 5]);
    }

    #[test]
    fn silhouettes_of_a_tetrahedron_and_a_plane() {
        let e = edges(&scene());
        // Seen from a point, an edge of a convex solid is a silhouette exactly when one of its
        // faces faces the point and the other does not.
        let y = DVec3::new(0.2, 10.0, 0.2);
        let facing = |f: u32| {
            let t = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]][f as usize];
            let v = [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z];
            (v[t[1]] - v[t[0]]).cross(v[t[2]] - v[t[0]]).dot(y - v[t[0]]) > 0.0
        };
        for edge in &e[..6] {
            assert_eq!(edge.is_potential_silhouette(y, 0.0), facing(edge.faces[0]) != facing(edge.faces[1]));
        }
        // The quad's diagonal is flat: never a silhouette from above or below, always one when
        // the ball reaches its plane; its boundary edges always are.
        let diagonal = e[6..].iter().find(|e| e.shared_by == 2).unwrap();
        assert!(!diagonal.is_potential_silhouette(DVec3::new(0.0, 3.0, 0.0), 1.0));
        assert!(!diagonal.is_potential_silhouette(DVec3::new(0.0, -3.0, 0.0), 1.0));
        assert!(diagonal.is_potential_silhouette(DVec3::new(0.0, -1.5, 0.0), 1.0));
        assert!(e[6..].iter().filter(|e| e.shared_by == 1).all(|e| e.is_potential_silhouette(DVec3::new(0.0, 3.0, 0.0), 0.5)));
    }
}
