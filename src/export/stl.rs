//! Binary STL through `stl_io`, vertices stored as f32 millimetres.

use crate::mesh::Mesh;

pub fn to_bytes(mesh: &Mesh) -> Vec<u8> {
    let v = mesh.to_f32();
    let tris: Vec<stl_io::Triangle> = mesh
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| v[i as usize]);
            let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            let w = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
            let mut n = [u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]];
            let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            if l > 0.0 {
                n = [n[0] / l, n[1] / l, n[2] / l];
            }
            stl_io::Triangle { normal: stl_io::Vector::new(n), vertices: [stl_io::Vector::new(a), stl_io::Vector::new(b), stl_io::Vector::new(c)] }
        })
        .collect();
    let mut out = Vec::new();
    stl_io::write_stl(&mut out, tris.iter()).expect("writing to memory cannot fail");
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Solid;

    #[test]
    fn stl_round_trips() {
        let m = Solid::cuboid([0.0; 3], [1.0, 2.0, 3.0]).to_mesh();
        let bytes = to_bytes(&m);
        assert_eq!(bytes.len(), 84 + 50 * m.triangles.len());
        let read = stl_io::read_stl(&mut std::io::Cursor::new(&bytes)).unwrap();
        assert_eq!(read.faces.len(), m.triangles.len());
        assert!(read.validate().is_ok());
    }
}
