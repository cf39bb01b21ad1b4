//! Edge adjacency of a scene's meshes and the light's potential silhouette edges.
//!
//! Every edge of every mesh appears once with the faces that share it (by vertex index, so an
//! unwelded mesh is all boundary edges: conservative, never wrong); an edge of three or more faces
//! appears once per face, as a one-sided edge, since what a face contributes along an edge (a
//! silhouette, a change in depth complexity) adds up face by face. An edge is a *silhouette* as
//! seen from a point `y` when its two faces fold back: their third vertices lie on the same side
//! of the plane through `y` and the edge. This test does not depend on how the faces are wound.
//! A *potential* silhouette of a light is an edge that is a silhouette from some point of the
//! light: occlusion as seen from a receiver can only change across the light where a segment to
//! the light crosses one (Sintorn et al. 2008, section 4.3; Akenine-Möller and Assarsson 2005).

use crate::geometry::mesh::Scene;
use crate::limits::Peak;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// One edge of a mesh: its end points and its one or two faces (global ids).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Edge {
    pub ends: [Vec3; 2],
    /// The third vertex of each face.
    pub opposite: [Vec3; 2],
    pub faces: [u32; 2],
    /// Whether the edge has two faces (a manifold edge); otherwise only `faces[0]` and
    /// `opposite[0]` count (a boundary edge, or one face of a non-manifold edge).
    pub two_faced: bool,
}

impl Edge {
    /// The faces' third vertices that count.
    pub fn opposites(&self) -> &[Vec3] {
        &self.opposite[..1 + usize::from(self.two_faced)]
    }
}

/// The memory of [`edges`] and of the silhouettes picked from them, with the influence-region
/// bins of each (at most three edges per face, each sorted key and its edge, twice over).
pub fn edges_peak(scene: &Scene) -> Peak {
    Peak::default().buffer(&[
        scene.num_faces() as u64,
        3,
        2 * (std::mem::size_of::<Edge>() as u64 + 16),
    ])
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
                    (
                        (u64::from(a) << 32) | u64::from(b),
                        f as u32,
                        v[(k + 2) % 3],
                    )
                })
            })
            .collect();
        keyed.par_sort_unstable();
        let pos = |i: u32| mesh.positions[i as usize];
        for group in keyed.chunk_by(|x, y| x.0 == y.0) {
            let ends = [pos((group[0].0 >> 32) as u32), pos(group[0].0 as u32)];
            let edge = |f: &[(u64, u32, u32)]| {
                let second = f.get(1).unwrap_or(&f[0]);
                Edge {
                    ends,
                    opposite: [pos(f[0].2), pos(second.2)],
                    faces: [first_face + f[0].1, first_face + second.1],
                    two_faced: f.len() == 2,
                }
            };
            if group.len() == 2 {
                out.push(edge(group));
            } else {
                out.extend(group.chunks(1).map(edge));
            }
        }
        first_face += mesh.faces.len() as u32;
    }
    out
}

/// The edges of the opaque meshes of `scene` that are silhouettes from some point of the ball
/// `(center, radius)`.
pub fn opaque_silhouettes(scene: &Scene, center: DVec3, radius: f64) -> Vec<Edge> {
    edges(scene)
        .into_par_iter()
        .filter(|e| {
            !scene.is_perforated_face(e.faces[0]) && e.is_potential_silhouette(center, radius)
        })
        .collect()
}

impl Edge {
    /// Whether some point of the ball `(center, radius)` sees this edge as a silhouette (always
    /// for a one-sided edge). Exact for a point light (`radius` 0); for a ball, the edge is
    /// cleared only when the ball lies strictly on one side of both face planes and on the side
    /// where the faces do not fold back.
    pub fn is_potential_silhouette(&self, center: DVec3, radius: f64) -> bool {
        if !self.two_faced {
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

/// `det[b − a, c − a, d − a]`: positive when `d` lies on the side of the plane `(a, b, c)` that
/// `(b − a) × (c − a)` points to.
fn orient(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> f64 {
    (b - a).cross(c - a).dot(d - a)
}

/// An edge seen from a receiver's shadow-ray origin `p` against a reference light point `y0`,
/// the per-edge step of depth complexity sampling (Forest, Barthe and Paulin 2008) and of
/// penumbra wedges (Assarsson and Akenine-Möller 2003). As a light point `y` moves from `y0`,
/// the number of faces the segment `p → y` meets changes only when the segment sweeps over an
/// edge, i.e. when the edge crosses the triangle `(p, y0, y)`; it then changes by [`Sweep::delta`]:
/// +1 for each face of the edge on `y`'s side of the plane through `p` and the edge (the segment
/// now meets it), −1 for each on `y0`'s side. An edge that is no silhouette as seen from `p` has
/// a face on each side and changes nothing.
#[derive(Debug, Clone, Copy)]
pub struct Sweep {
    a: DVec3,
    b: DVec3,
    p: DVec3,
    y0: DVec3,
    /// `orient(a, b, p, y0)`: which side of the edge's plane through `p` the reference lies on.
    side: f64,
    /// The change in the number of faces met when `y` crosses to the other side.
    pub delta: i32,
}

impl Edge {
    /// The sweep of this edge from `p` against `y0`; `None` when crossing it changes nothing
    /// (not a silhouette from `p`) or `y0` lies on the edge's plane through `p`.
    pub fn sweep(&self, p: DVec3, y0: DVec3) -> Option<Sweep> {
        let [a, b] = self.ends.map(|v| v.as_dvec3());
        let side = orient(a, b, p, y0);
        if side == 0.0 {
            return None;
        }
        let delta = self
            .opposites()
            .iter()
            .map(|c| {
                if orient(a, b, p, c.as_dvec3()) * side < 0.0 {
                    1
                } else {
                    -1
                }
            })
            .sum();
        (delta != 0).then_some(Sweep {
            a,
            b,
            p,
            y0,
            side,
            delta,
        })
    }

    /// The sweep of a penumbra wedge (Assarsson and Akenine-Möller 2003): as [`Edge::sweep`], but
    /// the edge counts once, +1 when `y` crosses to the side of the edge's plane through `p` where
    /// its faces extend (their mean direction from the edge), −1 the other way, even when the
    /// faces straddle that plane (an edge that is a silhouette from the light's center but not
    /// from `p`: the wedge's approximation). `None` when `y0` or the faces' direction lies on
    /// the plane.
    pub fn wedge_sweep(&self, p: DVec3, y0: DVec3) -> Option<Sweep> {
        let [a, b] = self.ends.map(|v| v.as_dvec3());
        let side = orient(a, b, p, y0);
        let inward: DVec3 = self.opposites().iter().map(|c| c.as_dvec3() - a).sum();
        let faces = orient(a, b, p, a + inward);
        if side == 0.0 || faces == 0.0 {
            return None;
        }
        let delta = if faces * side < 0.0 { 1 } else { -1 };
        Some(Sweep {
            a,
            b,
            p,
            y0,
            side,
            delta,
        })
    }
}

impl Sweep {
    /// Whether the edge crosses the triangle `(p, y0, y)` (strictly: ties count as no crossing),
    /// i.e. whether the segment from `p` sweeps over the edge as its end moves from `y0` to `y`.
    pub fn crosses(&self, y: DVec3) -> bool {
        let (a, b, p, y0) = (self.a, self.b, self.p, self.y0);
        // The line ab passes inside the triangle: the same turn about it from each triangle edge.
        if orient(a, b, y, p) * self.side <= 0.0 || orient(a, b, y0, y) * self.side <= 0.0 {
            return false;
        }
        // And the segment ab reaches the triangle's plane: a and b on opposite sides of it.
        orient(p, y0, y, a) * orient(p, y0, y, b) < 0.0
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
        let quad = vec![
            Vec3::new(-2.0, -1.0, -2.0),
            Vec3::new(2.0, -1.0, -2.0),
            Vec3::new(2.0, -1.0, 2.0),
            Vec3::new(-2.0, -1.0, 2.0),
        ];
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
        assert!(e[..6]
            .iter()
            .all(|e| e.two_faced && e.faces[0] != e.faces[1] && e.faces.iter().all(|&f| f < 4)));
        assert_eq!(e[6..].iter().filter(|e| !e.two_faced).count(), 4);
        let diagonal = e[6..].iter().find(|e| e.two_faced).unwrap();
        assert_eq!(diagonal.faces, [4, 5]);
    }

    #[test]
    fn non_manifold_edges_split_into_one_sided_edges() {
        // Three triangles around the x axis: a fin.
        let pos = vec![
            Vec3::ZERO,
            Vec3::X,
            Vec3::Y,
            Vec3::Z,
            Vec3::new(0.0, -1.0, -1.0),
        ];
        let mesh = Mesh::new(
            pos,
            vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]],
            None,
            None,
            false,
        )
        .unwrap();
        let e = edges(&Scene::new(vec![mesh]).unwrap());
        let axis: Vec<&Edge> = e
            .iter()
            .filter(|e| e.ends == [Vec3::ZERO, Vec3::X])
            .collect();
        assert_eq!(axis.len(), 3);
        assert!(axis
            .iter()
            .all(|e| !e.two_faced && e.opposites().len() == 1));
        assert_eq!(e.len(), 3 + 6);
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
            (v[t[1]] - v[t[0]])
                .cross(v[t[2]] - v[t[0]])
                .dot(y - v[t[0]])
                > 0.0
        };
        for edge in &e[..6] {
            assert_eq!(
                edge.is_potential_silhouette(y, 0.0),
                facing(edge.faces[0]) != facing(edge.faces[1])
            );
        }
        // The quad's diagonal is flat: never a silhouette from above or below, always one when
        // the ball reaches its plane; its boundary edges always are.
        let diagonal = e[6..].iter().find(|e| e.two_faced).unwrap();
        assert!(!diagonal.is_potential_silhouette(DVec3::new(0.0, 3.0, 0.0), 1.0));
        assert!(!diagonal.is_potential_silhouette(DVec3::new(0.0, -3.0, 0.0), 1.0));
        assert!(diagonal.is_potential_silhouette(DVec3::new(0.0, -1.5, 0.0), 1.0));
        assert!(e[6..]
            .iter()
            .filter(|e| !e.two_faced)
            .all(|e| e.is_potential_silhouette(DVec3::new(0.0, 3.0, 0.0), 0.5)));
    }

    #[test]
    fn sweeps_count_the_faces_a_segment_meets() {
        // A closed tetrahedron between a receiver and a line of light points: the number of faces
        // each segment meets, counted directly, equals the reference's count plus the deltas of
        // the edges crossed on the way.
        let scene = scene();
        let e = edges(&scene);
        let faces: Vec<[DVec3; 3]> = scene
            .triangles()
            .map(|(_, t)| t.map(|v| v.as_dvec3()))
            .collect();
        let meets = |p: DVec3, y: DVec3| {
            faces[..4]
                .iter()
                .filter(|t| {
                    let d = |x| orient(t[0], t[1], t[2], x);
                    d(p) * d(y) < 0.0 && {
                        let s = [
                            orient(p, y, t[0], t[1]),
                            orient(p, y, t[1], t[2]),
                            orient(p, y, t[2], t[0]),
                        ];
                        s.iter().all(|&v| v > 0.0) || s.iter().all(|&v| v < 0.0)
                    }
                })
                .count() as i32
        };
        let p = DVec3::new(0.23, -2.0, 0.31);
        let y0 = DVec3::new(-3.0, 4.0, 0.2);
        let mut changed = 0;
        for k in 0..=200 {
            let y = DVec3::new(
                -3.0 + 6.0 * k as f64 / 200.0,
                4.0,
                0.2 + 0.1 * (k as f64 * 0.37).sin(),
            );
            let counted = meets(p, y0)
                + e[..6]
                    .iter()
                    .filter_map(|edge| edge.sweep(p, y0))
                    .filter(|s| s.crosses(y))
                    .map(|s| s.delta)
                    .sum::<i32>();
            assert_eq!(counted, meets(p, y), "light point {y}");
            changed += i32::from(meets(p, y) != meets(p, y0));
        }
        assert!(
            changed > 20 && meets(p, y0) == 0,
            "the line of light points must pass behind the tetrahedron"
        );
    }
}
