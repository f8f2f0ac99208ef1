//! Inline shapes a scene file can declare without any OBJ: quads (grounds, plates, walls), boxes,
//! spheres and disks. They let the embedded scenes and the closed-form tests stand alone.

use glam::Vec3;

use super::Mesh;

/// A parallelogram `corner + s*edge_u + t*edge_v`, `s, t` in [0, 1], as two triangles.
pub fn quad(name: &str, corner: Vec3, edge_u: Vec3, edge_v: Vec3) -> Mesh {
    Mesh {
        name: name.to_string(),
        positions: vec![corner, corner + edge_u, corner + edge_u + edge_v, corner + edge_v],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
    }
}

/// An axis-aligned box between `min` and `max`, 12 outward-wound triangles sharing 8 vertices.
pub fn axis_box(name: &str, min: Vec3, max: Vec3) -> Mesh {
    let positions = (0..8)
        .map(|i| {
            Vec3::new(
                if i & 1 != 0 { max.x } else { min.x },
                if i & 2 != 0 { max.y } else { min.y },
                if i & 4 != 0 { max.z } else { min.z },
            )
        })
        .collect();
    // Faces as quads of corner indices (bit 0 = x, bit 1 = y, bit 2 = z), counter-clockwise from outside.
    const FACES: [[u32; 4]; 6] = [
        [0, 4, 6, 2], // -x
        [1, 3, 7, 5], // +x
        [0, 1, 5, 4], // -y
        [2, 6, 7, 3], // +y
        [0, 2, 3, 1], // -z
        [4, 5, 7, 6], // +z
    ];
    let triangles = FACES
        .iter()
        .flat_map(|f| [[f[0], f[1], f[2]], [f[0], f[2], f[3]]])
        .collect();
    Mesh {
        name: name.to_string(),
        positions,
        triangles,
    }
}

/// A UV sphere with `segments` around (>= 3) and `segments / 2` rings (>= 2), closed and manifold.
pub fn uv_sphere(name: &str, center: Vec3, radius: f32, segments: u32) -> Mesh {
    let rings = (segments / 2).max(2);
    let mut positions = vec![center + Vec3::Y * radius];
    for r in 1..rings {
        let phi = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..segments {
            let theta = std::f32::consts::TAU * s as f32 / segments as f32;
            let dir = Vec3::new(phi.sin() * theta.cos(), phi.cos(), phi.sin() * theta.sin());
            positions.push(center + dir * radius);
        }
    }
    let south = positions.len() as u32;
    positions.push(center - Vec3::Y * radius);
    let ring = |r: u32, s: u32| 1 + (r - 1) * segments + s % segments;
    let mut triangles = Vec::new();
    for s in 0..segments {
        triangles.push([0, ring(1, s + 1), ring(1, s)]);
        triangles.push([south, ring(rings - 1, s), ring(rings - 1, s + 1)]);
    }
    for r in 1..rings - 1 {
        for s in 0..segments {
            let (a, b, c, d) = (ring(r, s), ring(r, s + 1), ring(r + 1, s + 1), ring(r + 1, s));
            triangles.push([a, b, c]);
            triangles.push([a, c, d]);
        }
    }
    Mesh {
        name: name.to_string(),
        positions,
        triangles,
    }
}

/// A flat regular polygon with `segments` sides inscribed in the circle of `radius` around `center`,
/// perpendicular to `normal`, fanned from its centre. Its area is
/// `segments/2 * sin(2*pi/segments) * radius^2`, which the closed-form tests use exactly.
pub fn disk(name: &str, center: Vec3, normal: Vec3, radius: f32, segments: u32) -> Mesh {
    // A huge normal's squared length overflows f32 (glam's normalize then gives zero): scale by its
    // largest component first. Ordinary normals keep the direct form (bit-identical shapes).
    let unit = if normal.length_squared().is_finite() && normal.length_squared() > 1e-30 {
        normal.normalize()
    } else {
        (normal / normal.abs().max_element()).normalize()
    };
    let (t, b) = orthonormal_basis(unit);
    let mut positions = vec![center];
    for s in 0..segments {
        let a = std::f32::consts::TAU * s as f32 / segments as f32;
        positions.push(center + (t * a.cos() + b * a.sin()) * radius);
    }
    let triangles = (0..segments)
        .map(|s| [0, 1 + s, 1 + (s + 1) % segments])
        .collect();
    Mesh {
        name: name.to_string(),
        positions,
        triangles,
    }
}

/// Two unit vectors completing `n` (unit) to a right-handed orthonormal basis, without a branch on a
/// near-zero component (Duff et al., "Building an Orthonormal Basis, Revisited", JCGT 2017).
pub fn orthonormal_basis(n: Vec3) -> (Vec3, Vec3) {
    orthonormal_basis_counted(sism_simd::Portable, n)
}

/// [`orthonormal_basis`] with its operations counted by `s` (the same bits).
#[inline(always)]
pub fn orthonormal_basis_counted<S: sism_simd::Simd>(s: S, n: Vec3) -> (Vec3, Vec3) {
    use sism_simd::ScalarClass;
    let sign = s.s_fn(ScalarClass::Alu, n.z, |z| 1.0f32.copysign(z));
    let a = s.s_div(-1.0, s.s_add(sign, n.z));
    let b = s.s_mul(s.s_mul(n.x, n.y), a);
    // `-sign * n.x` is `(-sign) * n.x`: the same value as the negated product.
    let t = Vec3::new(
        s.s_add(1.0, s.s_mul(s.s_mul(s.s_mul(sign, n.x), n.x), a)),
        s.s_mul(sign, b),
        s.s_mul(-sign, n.x),
    );
    let bt = Vec3::new(b, s.s_add(sign, s.s_mul(s.s_mul(n.y, n.y), a)), -n.y);
    (t, bt)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn basis_is_orthonormal_for_awkward_normals() {
        for n in [Vec3::Z, -Vec3::Z, Vec3::X, Vec3::new(1.0, 2.0, -3.0).normalize()] {
            let (t, b) = orthonormal_basis(n);
            assert!((t.length() - 1.0).abs() < 1e-5 && (b.length() - 1.0).abs() < 1e-5);
            assert!(t.dot(n).abs() < 1e-5 && b.dot(n).abs() < 1e-5 && t.dot(b).abs() < 1e-5);
        }
    }

    #[test]
    fn sphere_is_closed() {
        let m = uv_sphere("s", Vec3::ZERO, 1.0, 12);
        // Euler characteristic of a sphere: V - E + F = 2, with E = 3F/2 for a closed triangle mesh.
        let (v, f) = (m.positions.len() as i64, m.triangles.len() as i64);
        assert_eq!(v - 3 * f / 2 + f, 2);
    }
}
