//! A body's surface from an STL file, binary or ASCII (read by the `stl_io` crate), in metres
//! as ROS gives meshes, or scaled (`0.001` for a CAD part drawn in millimetres). The triangles
//! are checked as a body by [`Body::mesh`]: closed, none of no area, facing outward.

use crate::model::{Body, ModelError, Triangle, place};
use std::io::Cursor;
use std::path::{Path, PathBuf};

/// Why an STL file gives no body.
#[derive(Debug, thiserror::Error)]
pub enum MeshFileError {
    /// The file cannot be read.
    #[error("cannot read the mesh {path}: {error}")]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        error: std::io::Error,
    },
    /// The bytes are no STL.
    #[error("{path} is no STL file: {why}")]
    NotStl {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        why: String,
    },
    /// A scale that is no positive number.
    #[error(
        "mesh scale {0} is no number > 0 (metres per unit of the file: 1 for metres, 0.001 for millimetres)"
    )]
    Scale(f64),
    /// The triangles are no closed body.
    #[error("the mesh {path} is no body: {error}")]
    Body {
        /// The file.
        path: PathBuf,
        /// What is wrong, naming the triangle, edge or value.
        error: ModelError,
    },
}

/// The triangles of the STL `bytes` (named `path` in errors), each vertex times `scale`.
pub fn parse_stl(path: &Path, bytes: &[u8], scale: f64) -> Result<Vec<Triangle>, MeshFileError> {
    if !(scale.is_finite() && scale > 0.0) {
        return Err(MeshFileError::Scale(scale));
    }
    let not = |why: String| MeshFileError::NotStl {
        path: path.to_path_buf(),
        why,
    };
    let ascii = bytes.trim_ascii_start().starts_with(b"solid")
        && std::str::from_utf8(&bytes[..bytes.len().min(512)])
            .is_ok_and(|s| s.contains("facet") || s.contains("endsolid"));
    // A binary STL's length is its count's: a file cut short or with bytes past its triangles
    // is said so, not read as what it happens to hold.
    if !ascii {
        if bytes.len() < 84 {
            return Err(not(format!(
                "{} bytes, fewer than a binary STL's 84-byte header and count, and no ASCII 'solid'",
                bytes.len()
            )));
        }
        let n = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as u64;
        let want = 84 + 50 * n;
        if want != bytes.len() as u64 {
            return Err(not(format!(
                "its header counts {n} triangles, 84 + 50 x {n} = {want} bytes, but it has {} bytes",
                bytes.len()
            )));
        }
    }
    let mut cursor = Cursor::new(bytes);
    let reader = stl_io::create_stl_reader(&mut cursor).map_err(|e| not(e.to_string()))?;
    let mut out = Vec::new();
    for (i, t) in reader.enumerate() {
        let t = t.map_err(|e| not(format!("triangle {i}: {e}")))?;
        out.push(t.vertices.map(|v| v.0.map(|c| f64::from(c) * scale)));
    }
    if out.is_empty() {
        return Err(not("it has no triangles".into()));
    }
    Ok(out)
}

/// The body of the STL file `path`, each vertex times `scale` (m per unit of the file), placed at
/// `xyz_m` and `rpy_rad` from the hub (see [`place`]), cut into elements of `element_m`.
pub fn read_body(
    path: &Path,
    scale: f64,
    xyz_m: [f64; 3],
    rpy_rad: [f64; 3],
    element_m: f64,
) -> Result<Body, MeshFileError> {
    let bytes = std::fs::read(path).map_err(|error| MeshFileError::Read {
        path: path.to_path_buf(),
        error,
    })?;
    let mut triangles = parse_stl(path, &bytes, scale)?;
    place(&mut triangles, xyz_m, rpy_rad);
    Body::mesh(&triangles, element_m).map_err(|error| MeshFileError::Body {
        path: path.to_path_buf(),
        error,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A cube of side 20 mm as binary STL (in mm) and the same as ASCII.
    fn cube_triangles() -> Vec<Triangle> {
        crate::model::box_triangles([20.0; 3], [0.0; 3])
    }

    fn binary(t: &[Triangle]) -> Vec<u8> {
        let tris: Vec<stl_io::Triangle> = t
            .iter()
            .map(|t| stl_io::Triangle {
                normal: stl_io::Normal::new([0.0; 3]),
                vertices: t.map(|v| stl_io::Vertex::new(v.map(|c| c as f32))),
            })
            .collect();
        let mut out = Vec::new();
        stl_io::write_stl(&mut out, tris.iter()).unwrap();
        out
    }

    fn ascii(t: &[Triangle]) -> String {
        let mut s = String::from("solid cube\n");
        for t in t {
            s += "  facet normal 0 0 0\n    outer loop\n";
            for v in t {
                s += &format!("      vertex {} {} {}\n", v[0], v[1], v[2]);
            }
            s += "    endloop\n  endfacet\n";
        }
        s + "endsolid cube\n"
    }

    #[test]
    fn binary_and_ascii_stl_in_mm_give_the_same_body_in_metres() {
        let p = Path::new("cube.stl");
        let b = parse_stl(p, &binary(&cube_triangles()), 0.001).unwrap();
        let a = parse_stl(p, ascii(&cube_triangles()).as_bytes(), 0.001).unwrap();
        assert_eq!(a.len(), 12);
        for (x, y) in a.iter().zip(&b) {
            for k in 0..3 {
                for j in 0..3 {
                    assert!((x[k][j] - y[k][j]).abs() < 1e-9);
                }
            }
        }
        let body = Body::mesh(&a, 0.005).unwrap();
        assert!((body.reach_m() - 0.01).abs() < 1e-9 && (body.height_m() - 0.02).abs() < 1e-9);
    }

    #[test]
    fn a_bad_stl_is_an_error_naming_what_is_wrong() {
        let p = Path::new("foot.stl");
        let good = binary(&cube_triangles());
        let e = parse_stl(p, &good[..good.len() - 7], 0.001)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("foot.stl") && e.contains("12 triangles") && e.contains("677 bytes"),
            "{e}"
        );
        let e = parse_stl(p, b"hello", 1.0).unwrap_err().to_string();
        assert!(e.contains("5 bytes"), "{e}");
        let e = parse_stl(p, &good, 0.0).unwrap_err().to_string();
        assert!(e.contains("mesh scale 0"), "{e}");
        let e = parse_stl(
            p,
            b"solid x\n facet normal 0 0 0\n outer loop\n vertex 1 2\n",
            1.0,
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("foot.stl is no STL file"), "{e}");
        // An open mesh: a triangle gone.
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("open.stl");
        std::fs::write(&f, binary(&cube_triangles()[1..])).unwrap();
        let e = read_body(&f, 0.001, [0.0; 3], [0.0; 3], 0.005)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("open.stl is no body") && e.contains("not closed"),
            "{e}"
        );
        let e = read_body(&dir.path().join("none.stl"), 1.0, [0.0; 3], [0.0; 3], 0.005)
            .unwrap_err()
            .to_string();
        assert!(e.contains("cannot read the mesh"), "{e}");
    }
}
